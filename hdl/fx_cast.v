// fx_cast: quantise-then-overflow cast of an exact value into a fixed-point format.
//
// rangefx P1 (docs/p1_datapath.md, rtl_model/fixedpoint.py): the exact value
// x * 2^-IN_F (x a 64-bit two's complement integer) is rounded to a multiple of
// 2^-OUT_F with the quantisation mode QUANT, then brought into the OUT_W-bit range
// with the overflow mode OVF (Vitis HLS ap_fixed names and meanings):
//   QUANT: 0 TRN, 1 TRN_ZERO, 2 RND, 3 RND_ZERO, 4 RND_INF, 5 RND_MIN_INF, 6 RND_CONV
//   OVF:   0 WRAP, 1 SAT, 2 SAT_ZERO, 3 SAT_SYM
// Combinational. Supports 0 <= IN_F - OUT_F <= 62 (dropping bits) and left shifts whose
// result fits 64 bits (the word-length config guarantees this for P1's casts).
`timescale 1ns / 1ps
module fx_cast #(
    parameter integer IN_F  = 0,
    parameter integer OUT_W = 8,
    parameter integer OUT_F = 0,
    parameter integer OUT_S = 0,   // 1: two's complement result, 0: unsigned
    parameter integer QUANT = 0,
    parameter integer OVF   = 0
) (
    input  wire signed [63:0]      x,
    output reg         [OUT_W-1:0] y,
    output reg                     ovf
);
    localparam integer SH = IN_F - OUT_F;
    localparam integer SHP = (SH > 0) ? SH : 1;      // shift used when dropping bits
    localparam integer SHL = (SH < 0) ? -SH : 0;     // shift used when adding bits

    reg signed [65:0] xe, q, hi, lo;
    reg        [63:0] rem, half;
    reg               above, tie, neg, up;

    always @* begin
        xe = x;
        neg = x[63];  // floor(x / 2^SH) < 0 exactly when x < 0
        if (SH > 0) begin
            q    = xe >>> SHP;
            rem  = x & ((64'd1 << SHP) - 64'd1);
            half = 64'd1 << (SHP - 1);
        end else begin
            q    = xe <<< SHL;
            rem  = 64'd0;
            half = 64'd1;
        end
        above = rem > half;
        tie   = (SH > 0) && (rem == half);
        case (QUANT)
            0: up = 1'b0;                           // TRN: toward -inf
            1: up = neg && (rem != 64'd0);          // TRN_ZERO: toward zero
            2: up = above | tie;                    // RND: ties toward +inf
            3: up = above | (tie & neg);            // RND_ZERO: ties toward zero
            4: up = above | (tie & ~neg);           // RND_INF: ties away from zero
            5: up = above;                          // RND_MIN_INF: ties toward -inf
            6: up = above | (tie & q[0]);           // RND_CONV: ties to even
            default: up = 1'b0;
        endcase
        q = q + $signed({65'd0, up});
        if (OUT_S != 0) begin
            hi = (66'sd1 <<< (OUT_W - 1)) - 66'sd1;
            lo = -hi - 66'sd1;
            // SAT_SYM never gives -2^(W-1); for W = 1 ap_fixed keeps -1 (as SAT)
            if (OVF == 3 && OUT_W > 1) lo = -hi;
        end else begin
            hi = (66'sd1 <<< OUT_W) - 66'sd1;
            lo = 66'sd0;
        end
        if (q >= lo && q <= hi) begin
            y   = q[OUT_W-1:0];
            ovf = 1'b0;
        end else begin
            ovf = 1'b1;
            case (OVF)
                0: y = q[OUT_W-1:0];                // WRAP: low W bits
                2: y = {OUT_W{1'b0}};               // SAT_ZERO
                default: y = (q > hi) ? hi[OUT_W-1:0] : lo[OUT_W-1:0];  // SAT, SAT_SYM
            endcase
        end
    end
endmodule
