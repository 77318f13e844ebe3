// fx_cast_sized: quantise-then-overflow cast of an exact fixed-point value, every
// datapath width sized to the two formats (rangefx docs/p1_datapath.md `cast(v, S)`,
// rtl_model/fixedpoint.py; Vitis HLS ap_fixed names and meanings).
//
// The exact value x * 2^-IN_F (x an IN_W-bit word, two's complement if IN_S) is rounded
// to a multiple of 2^-OUT_F with the quantisation mode QUANT, then brought into the
// OUT_W-bit range with the overflow mode OVF:
//   QUANT: 0 TRN, 1 TRN_ZERO, 2 RND, 3 RND_ZERO, 4 RND_INF, 5 RND_MIN_INF, 6 RND_CONV
//   OVF:   0 WRAP, 1 SAT, 2 SAT_ZERO, 3 SAT_SYM
// `ovf` is high when the overflow mode had to act (for SAT_SYM also on -2^(OUT_W-1)),
// as the model counts it. Combinational. Any IN_F - OUT_F (dropping or adding bits).
// Unlike a generic 64-bit cast, the quotient, remainder and range comparisons are only
// as wide as the formats need, so synthesis sees the real cost of each signal's width.
`timescale 1ns / 1ps
module fx_cast_sized #(
    parameter integer IN_W  = 16,
    parameter integer IN_F  = 0,
    parameter integer IN_S  = 1,
    parameter integer OUT_W = 8,
    parameter integer OUT_F = 0,
    parameter integer OUT_S = 0,
    parameter integer QUANT = 0,
    parameter integer OVF   = 0
) (
    input  wire [IN_W-1:0]  x,
    output reg  [OUT_W-1:0] y,
    output reg              ovf
);
    localparam integer SH   = IN_F - OUT_F;
    localparam integer DROP = (SH > 0) ? SH : 0;              // LSBs dropped
    localparam integer SHL  = (SH < 0) ? -SH : 0;             // LSBs added
    localparam integer DRW  = (DROP > 0) ? DROP : 1;          // width of the remainder
    localparam integer XW   = ((IN_W > DROP) ? IN_W : DROP) + 1;  // signed, holds x and rem
    localparam integer FLW  = XW - DROP;                      // signed floor quotient
    localparam integer QB   = FLW + SHL;                      // ... with the bits added
    localparam integer QW   = ((QB > OUT_W) ? QB : OUT_W) + 2;    // + rounding carry, + sign

    wire neg = (IN_S != 0) && x[IN_W-1];
    wire signed [XW-1:0] xe = {{(XW-IN_W){neg}}, x};
    wire signed [XW-1:0] fl = xe >>> DROP;                    // floor(x / 2^DROP)
    wire [DRW-1:0] rem = (DROP > 0) ? xe[DRW-1:0] : {DRW{1'b0}};
    wire [DRW-1:0] lsb = 1;
    wire [DRW-1:0] half = lsb << (DRW - 1);
    wire above = (DROP > 0) && (rem > half);
    wire tie   = (DROP > 0) && (rem == half);
    wire inexact = (DROP > 0) && (rem != {DRW{1'b0}});
    reg up;
    always @* begin
        case (QUANT)
            1: up = neg & inexact;                            // TRN_ZERO: toward zero
            2: up = above | tie;                              // RND: ties toward +inf
            3: up = above | (tie & neg);                      // RND_ZERO: ties toward zero
            4: up = above | (tie & ~neg);                     // RND_INF: ties away from zero
            5: up = above;                                    // RND_MIN_INF: ties toward -inf
            6: up = above | (tie & fl[0]);                    // RND_CONV: ties to even
            default: up = 1'b0;                               // TRN: toward -inf
        endcase
    end
    wire signed [QW-1:0] q = ($signed({{(QW-FLW){fl[FLW-1]}}, fl[FLW-1:0]}) <<< SHL)
                             + $signed({{(QW-1){1'b0}}, up});
    // range of the output format
    wire signed [QW-1:0] one = {{(QW-1){1'b0}}, 1'b1};
    wire signed [QW-1:0] hi = (OUT_S != 0) ? (one <<< (OUT_W - 1)) - one : (one <<< OUT_W) - one;
    // SAT_SYM never gives -2^(W-1); for W = 1 ap_fixed keeps -1 (as SAT)
    wire signed [QW-1:0] lo = (OUT_S == 0) ? {QW{1'b0}}
                              : ((OVF == 3 && OUT_W > 1) ? -hi : -hi - one);
    always @* begin
        if (q >= lo && q <= hi) begin
            y   = q[OUT_W-1:0];
            ovf = 1'b0;
        end else begin
            ovf = 1'b1;
            case (OVF)
                0: y = q[OUT_W-1:0];                          // WRAP: low W bits
                2: y = {OUT_W{1'b0}};                         // SAT_ZERO
                default: y = (q > hi) ? hi[OUT_W-1:0] : lo[OUT_W-1:0];  // SAT, SAT_SYM
            endcase
        end
    end
endmodule
