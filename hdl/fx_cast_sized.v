// Casts sized to their formats: quantise, then overflow (docs/p1_datapath.md "cast").
//
// rangefx: the same modes and meanings as hdl/fx_cast.v (Vitis HLS ap_fixed names):
//   QUANT: 0 TRN, 1 TRN_ZERO, 2 RND, 3 RND_ZERO, 4 RND_INF, 5 RND_MIN_INF, 6 RND_CONV
//   OVF:   0 WRAP, 1 SAT, 2 SAT_ZERO, 3 SAT_SYM
// but every internal word is as wide as the input word and the output format need, not
// 64 bits: the input is an IN_W-bit two's complement exact value, the quantised value is
// carried in max(input bits kept, OUT_W + 1) + 1 bits.
//
//   fx_round, fx_sat: the rounding carry; the overflow mode
//   fx_round_sat : both in one, shared by both casts below
//   fx_quant_sized: the quantisation half: floor and the dropped bits' class
//   fx_cast_sized: a cast whose shift IN_F - OUT_F is a parameter (any sign)
//   fx_cast_reg  : fx_cast_sized with its rounded value registered (latency 1)
//   fx_cast_var  : a right shift that varies per sample (the reciprocal divider's
//                  normalisation), 0 <= sh < 2^SH_W
// All combinational but fx_cast_reg (one register between rounding and overflow) and
// fx_cast_var with REG = 1 (one register between shift and rounding; REG = 2: and one
// between rounding and overflow).
`timescale 1ns / 1ps

// The rounded value: floor q plus the rounding carry of the quantisation mode, in
// CW = max(QW, OUT_W + 1) + 1 bits (fx_round_sat, or fx_cast_var with REG = 2).
module fx_round #(
    parameter integer QW    = 8,   // bits of the floor q (two's complement)
    parameter integer OUT_W = 8,
    parameter integer QUANT = 0
) (
    input  wire signed [QW-1:0]    q,        // floor(x / 2^sh)
    input  wire                    above,    // remainder > 1/2 LSB
    input  wire                    tie,      // remainder == 1/2 LSB (and sh > 0)
    input  wire                    nonzero,  // remainder != 0
    output reg  signed [((QW > OUT_W + 1) ? QW : OUT_W + 1):0] qr
);
    localparam integer CW = ((QW > OUT_W + 1) ? QW : OUT_W + 1) + 1;
    wire neg = q[QW-1];  // floor(x / 2^sh) < 0 exactly when x < 0
    reg  up;
    always @* begin
        case (QUANT)
            0: up = 1'b0;                       // TRN: toward -inf
            1: up = neg & nonzero;              // TRN_ZERO: toward zero
            2: up = above | tie;                // RND: ties toward +inf
            3: up = above | (tie & neg);        // RND_ZERO: ties toward zero
            4: up = above | (tie & ~neg);       // RND_INF: ties away from zero
            5: up = above;                      // RND_MIN_INF: ties toward -inf
            6: up = above | (tie & q[0]);       // RND_CONV: ties to even
            default: up = 1'b0;
        endcase
        qr = q;  // sign-extended to CW bits
        qr = qr + $signed({{(CW-1){1'b0}}, up});
    end
endmodule

// The overflow mode acting on a rounded value qr of CW bits, into OUT_W bits.
module fx_sat #(
    parameter integer CW    = 10,
    parameter integer OUT_W = 8,
    parameter integer OUT_S = 0,
    parameter integer OVF   = 0
) (
    input  wire signed [CW-1:0]    qr,
    output reg         [OUT_W-1:0] y,
    output reg                     ovf
);
    localparam [CW-1:0] ONE = {{(CW-1){1'b0}}, 1'b1};
    // the largest and smallest codes of the output format
    localparam [CW-1:0] HI = OUT_S ? (ONE << (OUT_W - 1)) - ONE : (ONE << OUT_W) - ONE;
    localparam [CW-1:0] LO_SAT = OUT_S ? ~HI : {CW{1'b0}};
    // SAT_SYM never gives -2^(W-1); for W = 1 ap_fixed keeps -1 (as SAT)
    localparam integer SYM = (OUT_S && OVF == 3 && OUT_W > 1) ? 1 : 0;
    localparam [CW-1:0] LO = SYM ? ~HI + ONE : LO_SAT;
    // the bits above the output word (from its sign bit when signed) must repeat the sign
    localparam integer TOP = OUT_S ? OUT_W - 1 : OUT_W;
    reg above_hi, below_lo;
    always @* begin
        // range checks on the top bits, not CW-bit comparisons
        above_hi = ~qr[CW-1] & (|qr[CW-2:TOP]);
        below_lo = qr[CW-1] & (OUT_S ? ~(&qr[CW-2:TOP]) : 1'b1);
        if (SYM) below_lo = below_lo | (qr == $signed(LO_SAT));
        ovf = above_hi | below_lo;
        case (OVF)
            0: y = qr[OUT_W-1:0];                                     // WRAP
            2: y = ovf ? {OUT_W{1'b0}} : qr[OUT_W-1:0];               // SAT_ZERO
            default: y = above_hi ? HI[OUT_W-1:0] : (below_lo ? LO[OUT_W-1:0] : qr[OUT_W-1:0]);
        endcase
    end
endmodule

// Rounding carry from (floor q, remainder class) and overflow into OUT_W bits.
module fx_round_sat #(
    parameter integer QW    = 8,   // bits of the floor q (two's complement)
    parameter integer OUT_W = 8,
    parameter integer OUT_S = 0,
    parameter integer QUANT = 0,
    parameter integer OVF   = 0
) (
    input  wire signed [QW-1:0]    q,        // floor(x / 2^sh)
    input  wire                    above,    // remainder > 1/2 LSB
    input  wire                    tie,      // remainder == 1/2 LSB (and sh > 0)
    input  wire                    nonzero,  // remainder != 0
    output wire        [OUT_W-1:0] y,
    output wire                    ovf
);
    localparam integer CW = ((QW > OUT_W + 1) ? QW : OUT_W + 1) + 1;
    wire signed [CW-1:0] qr;
    fx_round #(QW, OUT_W, QUANT) u_r (.q(q), .above(above), .tie(tie), .nonzero(nonzero),
                                      .qr(qr));
    fx_sat #(CW, OUT_W, OUT_S, OVF) u_s (.qr(qr), .y(y), .ovf(ovf));
endmodule

// x * 2^-IN_F (IN_W-bit two's complement) as floor(x 2^-SH), SH = IN_F - OUT_F, and the
// class of the dropped bits (the quantisation half of a cast; QW as fx_cast_sized's).
module fx_quant_sized #(
    parameter integer IN_W  = 16,
    parameter integer IN_F  = 0,
    parameter integer OUT_F = 0,
    parameter integer QW    = 16
) (
    input  wire signed [IN_W-1:0]  x,
    output wire signed [QW-1:0]    q,
    output wire                    above,
    output wire                    tie,
    output wire                    nonzero
);
    localparam integer SH = IN_F - OUT_F;
    localparam integer SHP = (SH > 0) ? SH : 1;
    localparam integer SHL = (SH < 0) ? -SH : 0;
    localparam integer XW = (SH > 0) ? ((IN_W > SHP) ? IN_W : SHP + 1) : IN_W + SHL;
    generate
        if (SH > 0) begin : g_drop
            wire signed [XW-1:0]  xe = x;
            wire        [SHP-1:0] rem = xe[SHP-1:0];
            assign q = xe >>> SHP;
            // rem against half = 2^(SH-1) without a carry chain (Yosys maps a comparison
            // with a constant to one): the bit at SH - 1 and whether any bit below is set
            if (SHP > 1) begin : g_lo
                wire low = |rem[SHP-2:0];
                assign above = rem[SHP-1] & low;
                assign tie = rem[SHP-1] & ~low;
            end else begin : g_one
                assign above = 1'b0;
                assign tie = rem[0];
            end
            assign nonzero = |rem;
        end else begin : g_keep
            wire signed [XW-1:0] xe = x;
            assign q = xe <<< SHL;
            assign above = 1'b0;
            assign tie = 1'b0;
            assign nonzero = 1'b0;
        end
    endgenerate
endmodule

// x * 2^-IN_F (IN_W-bit two's complement) cast into (OUT_S, OUT_W, OUT_F).
module fx_cast_sized #(
    parameter integer IN_W  = 16,
    parameter integer IN_F  = 0,
    parameter integer OUT_W = 8,
    parameter integer OUT_F = 0,
    parameter integer OUT_S = 0,
    parameter integer QUANT = 0,
    parameter integer OVF   = 0
) (
    input  wire signed [IN_W-1:0]  x,
    output wire        [OUT_W-1:0] y,
    output wire                    ovf
);
    localparam integer SH = IN_F - OUT_F;
    localparam integer SHP = (SH > 0) ? SH : 1;
    localparam integer SHL = (SH < 0) ? -SH : 0;
    // a right shift of SH >= IN_W bits leaves 0 or -1: extend x so the remainder is exact
    localparam integer XW = (SH > 0) ? ((IN_W > SHP) ? IN_W : SHP + 1) : IN_W + SHL;
    localparam integer QW = (SH > 0) ? XW - SHP + 1 : XW;

    wire signed [QW-1:0] q;
    wire above, tie, nonzero;
    fx_quant_sized #(IN_W, IN_F, OUT_F, QW) u_q (
        .x(x), .q(q), .above(above), .tie(tie), .nonzero(nonzero));
    fx_round_sat #(QW, OUT_W, OUT_S, QUANT, OVF) u_rs (
        .q(q), .above(above), .tie(tie), .nonzero(nonzero), .y(y), .ovf(ovf));
endmodule

// fx_cast_sized in two clock stages (latency 1): the rounded value registered before
// the overflow mode, so no cycle holds both the rounding increment (a carry chain) and
// the saturation (P1's range stage, hdl/p1_range.v).
module fx_cast_reg #(
    parameter integer IN_W  = 16,
    parameter integer IN_F  = 0,
    parameter integer OUT_W = 8,
    parameter integer OUT_F = 0,
    parameter integer OUT_S = 0,
    parameter integer QUANT = 0,
    parameter integer OVF   = 0
) (
    input  wire                    clk,
    input  wire signed [IN_W-1:0]  x,
    output wire        [OUT_W-1:0] y,
    output wire                    ovf
);
    localparam integer SH = IN_F - OUT_F;
    localparam integer SHP = (SH > 0) ? SH : 1;
    localparam integer SHL = (SH < 0) ? -SH : 0;
    localparam integer XW = (SH > 0) ? ((IN_W > SHP) ? IN_W : SHP + 1) : IN_W + SHL;
    localparam integer QW = (SH > 0) ? XW - SHP + 1 : XW;
    localparam integer CW = ((QW > OUT_W + 1) ? QW : OUT_W + 1) + 1;

    wire signed [QW-1:0] q;
    wire above, tie, nonzero;
    fx_quant_sized #(IN_W, IN_F, OUT_F, QW) u_q (
        .x(x), .q(q), .above(above), .tie(tie), .nonzero(nonzero));
    wire signed [CW-1:0] qr;
    fx_round #(QW, OUT_W, QUANT) u_r (.q(q), .above(above), .tie(tie), .nonzero(nonzero),
                                      .qr(qr));
    reg signed [CW-1:0] qr_r;
    always @(posedge clk) qr_r <= qr;
    fx_sat #(CW, OUT_W, OUT_S, OVF) u_s (.qr(qr_r), .y(y), .ovf(ovf));
endmodule

// x >> sh with rounding (sh per sample, 0 <= sh < 2^SH_W), into (OUT_S, OUT_W).
module fx_cast_var #(
    parameter integer IN_W  = 16,
    parameter integer SH_W  = 5,
    parameter integer SH_MAX = 31,  // the largest sh that occurs
    parameter integer OUT_W = 8,
    parameter integer OUT_S = 0,
    parameter integer QUANT = 0,
    parameter integer OVF   = 0,
    parameter integer REG   = 0     // 1: the shifted value and remainder class registered,
                                    // 2: and the rounded value (latency 2)
) (
    input  wire                    clk,
    input  wire signed [IN_W-1:0]  x,
    input  wire        [SH_W-1:0]  sh,
    output wire        [OUT_W-1:0] y,
    output wire                    ovf
);
    localparam integer XW = (IN_W > SH_MAX + 1) ? IN_W : SH_MAX + 1;
    wire signed [XW-1:0] xe = x;
    // the dropped bits rem = x mod 2^sh against half = 2^(sh-1), without a carry chain:
    // the bit at sh - 1 and whether any bit below it is set (sh = 0: no bit, no tie)
    wire        [XW-1:0] m_lo = ~({XW{1'b1}} << sh);     // bits below sh
    wire        [XW-1:0] m_below = m_lo >> 1;            // bits below sh - 1
    wire                 hbit = |(xe & (m_lo ^ m_below));
    wire                 low = |(xe & m_below);
    wire signed [XW-1:0] q = xe >>> sh;
    wire signed [XW-1:0] q_r;
    wire                 above_r, tie_r, nonzero_r;
    generate
        if (REG != 0) begin : g_reg
            reg signed [XW-1:0] q1;
            reg                 a1, t1, n1;
            always @(posedge clk) {q1, a1, t1, n1} <= {q, hbit & low, hbit & ~low, hbit | low};
            assign {q_r, above_r, tie_r, nonzero_r} = {q1, a1, t1, n1};
        end else begin : g_comb
            assign {q_r, above_r, tie_r, nonzero_r} = {q, hbit & low, hbit & ~low, hbit | low};
        end
    endgenerate
    localparam integer CW = ((XW > OUT_W + 1) ? XW : OUT_W + 1) + 1;
    wire signed [CW-1:0] qr;
    fx_round #(XW, OUT_W, QUANT) u_r (.q(q_r), .above(above_r), .tie(tie_r),
                                      .nonzero(nonzero_r), .qr(qr));
    wire signed [CW-1:0] qr_r;
    generate
        if (REG > 1) begin : g_reg2
            reg signed [CW-1:0] q2;
            always @(posedge clk) q2 <= qr;
            assign qr_r = q2;
        end else begin : g_comb2
            assign qr_r = qr;
        end
    endgenerate
    fx_sat #(CW, OUT_W, OUT_S, OVF) u_s (.qr(qr_r), .y(y), .ovf(ovf));
endmodule
