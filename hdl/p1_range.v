// p1_range: rangefx P1 range stage (eq 28 of the obstacle paper), one pixel per clock.
//
// Bit-exact with docs/p1_datapath.md "Range stage" steps 1-8: pixel counters and
// coordinates xp, yp; c1, a1, b1; k0..k2; vx, vy, wx, wy, w0; gv, num, den, v_sq, g_sq,
// g_thr; the range divider (restoring or reciprocal, fx_divide.v); the thresholds, valid
// and the range output. Every cast is fx_cast_sized, its exact input carried in as many
// bits as its operands' formats need. Formats and modes are parameters, each signal's
// <P>_W, _F, _S (signed), _Q (quantisation), _O (overflow); rangefx.vectors.hdl
// .range_parameters(config, width, height) computes them from a word-length config.
//
// Input: one beat per clock when s_valid (no back-pressure), s_sof = first pixel of a
// frame, s_eol = last pixel of a line; the two streams' outputs E_hat (col_s1), ex
// (div_quot or col2_out) and ey (col_s2) of the same pixel. The pipeline advances every
// clock, one carry chain or one product (fx_mul_pipe, FX_MUL_LAT = 4 stages: operands
// and partial products in the MULT18X18D's registers, two sums) per cycle: three-term
// sums take two cycles, every cast two (fx_cast_reg: the rounded value registered before
// the overflow mode), the divider's flags are formed from earlier registers. Each tap
// group leaves at a fixed latency after its input beat, as rtl_model/p1/model.py
// stage_latencies declares (the schedule: docs/hdl.md):
//   range_coords   +19               : xp yp c1 a1 b1 k0 k1 k2 vx vy wx wy w0  (c_valid)
//   range_products +14 (+33 in all)  : gv num den v_sq g_sq g_thr              (p_valid)
//   range_divider  +1 + DIV_LAT      : range_q                                 (q_valid)
//   threshold      +1                : valid, range                            (m_valid)
// Each group's cast overflow flags leave with it (ovf_c, ovf_p, ovf_q; bit order as the
// tap lists above). Host registers (raw codes in their register formats) are ports.
`timescale 1ns / 1ps
module p1_range #(
    parameter integer X_W = 10,          // column counter bits
    parameter integer Y_W = 10,          // row counter bits
    parameter integer DIVIDER = 1,       // 0 restoring, 1 reciprocal
    parameter integer RECIP_L = 8,
    parameter integer RECIP_R = 20,
    parameter ROM_FILE = "recip_rom.mem",
    // stream inputs
    parameter integer S1_W = 20, parameter integer S1_F = 11, parameter integer S1_S = 0,
    parameter integer EX_W = 24, parameter integer EX_F = 12, parameter integer EX_S = 1,
    parameter integer S2_W = 21, parameter integer S2_F = 11, parameter integer S2_S = 1,
`include "p1_range_params.vh"
) (
    input  wire             clk,
    input  wire             rst,
    // host registers (docs/p1_datapath.md "Registers")
    input  wire [CO_W-1:0]  cx_raw,
    input  wire [CO_W-1:0]  cy_raw,
    input  wire [FR_W-1:0]  f_raw,
    input  wire [KT_W-1:0]  k3_raw,
    input  wire [KT_W-1:0]  k4_raw,
    input  wire [KT_W-1:0]  k5_raw,
    input  wire [9*KM_W-1:0] m_raw,      // M_00 M_01 M_02 M_10 ... M_22, M_00 in the low bits
    input  wire [C1_W-1:0]  te_raw,
    input  wire [TG2_W-1:0] tg2_raw,
    input  wire [DEN_W-1:0] dmin_raw,
    input  wire [RNG_W-1:0] rmax_raw,
    // the two streams' outputs of one pixel
    input  wire             s_valid,
    input  wire             s_sof,
    input  wire             s_eol,
    input  wire [S1_W-1:0]  e1_s1,
    input  wire [EX_W-1:0]  e1_ex,
    input  wire [S2_W-1:0]  e1_s2,
    input  wire [S1_W-1:0]  e2_s1,
    input  wire [EX_W-1:0]  e2_ex,
    input  wire [S2_W-1:0]  e2_s2,
    // range_coords taps
    output reg              c_valid,
    output reg  [CO_W-1:0]  xp,
    output reg  [CO_W-1:0]  yp,
    output reg  [C1_W-1:0]  c1,
    output reg  [GA_W-1:0]  a1,
    output reg  [GB_W-1:0]  b1,
    output reg  [KR_W-1:0]  k0,
    output reg  [KR_W-1:0]  k1,
    output reg  [KR_W-1:0]  k2,
    output reg  [V_W-1:0]   vx,
    output reg  [V_W-1:0]   vy,
    output reg  [W_W-1:0]   wx,
    output reg  [W_W-1:0]   wy,
    output reg  [W_W-1:0]   w0,
    output reg  [12:0]      ovf_c,
    // range_products taps
    output reg              p_valid,
    output reg  [GV_W-1:0]  gv,
    output reg  [NUM_W-1:0] num,
    output reg  [DEN_W-1:0] den,
    output reg  [VSQ_W-1:0] v_sq,
    output reg  [GSQ_W-1:0] g_sq,
    output reg  [GSQ_W-1:0] g_thr,
    output reg  [5:0]       ovf_p,
    // range_divider tap
    output wire             q_valid,
    output wire [RNG_W-1:0] range_q,
    output wire             ovf_q,
    // outputs (threshold stage)
    output reg              m_valid,
    output reg              m_sof,
    output reg              m_eol,
    output reg              valid,
    output reg  [RNG_W-1:0] range
);
`define RFX_MAX(a, b) (((a) > (b)) ? (a) : (b))
// a raw code as a two's complement value one bit wider when unsigned
`define RFX_SX(v, S) (((S) != 0) ? $signed(v) : $signed({1'b0, v}))
    // two's complement widths of the formats
    localparam integer S1_SW = S1_W + (S1_S ? 0 : 1);
    localparam integer EX_SW = EX_W + (EX_S ? 0 : 1);
    localparam integer S2_SW = S2_W + (S2_S ? 0 : 1);
    localparam integer FR_SW = FR_W + (FR_S ? 0 : 1);
    localparam integer KT_SW = KT_W + (KT_S ? 0 : 1);
    localparam integer KM_SW = KM_W + (KM_S ? 0 : 1);
    localparam integer TG2_SW = TG2_W + (TG2_S ? 0 : 1);
    localparam integer CO_SW = CO_W + (CO_S ? 0 : 1);
    localparam integer C1_SW = C1_W + (C1_S ? 0 : 1);
    localparam integer GA_SW = GA_W + (GA_S ? 0 : 1);
    localparam integer GB_SW = GB_W + (GB_S ? 0 : 1);
    localparam integer KR_SW = KR_W + (KR_S ? 0 : 1);
    localparam integer V_SW = V_W + (V_S ? 0 : 1);
    localparam integer W_SW = W_W + (W_S ? 0 : 1);
    localparam integer GV_SW = GV_W + (GV_S ? 0 : 1);
    localparam integer NUM_SW = NUM_W + (NUM_S ? 0 : 1);
    localparam integer DEN_SW = DEN_W + (DEN_S ? 0 : 1);
    localparam integer RNG_SW = RNG_W + (RNG_S ? 0 : 1);
    localparam integer VSQ_SW = VSQ_W + (VSQ_S ? 0 : 1);
    localparam integer GSQ_SW = GSQ_W + (GSQ_S ? 0 : 1);
    // latencies (rtl_model/p1/model.py stage_latencies): range_coords, range_products, and
    // the divider's own (runtime.divider_latency plus its registered operand normalisation)
    localparam integer FX_MUL_LAT = 4;                // fx_mul_pipe IREG = 1
    localparam integer CAST_LAT = 2;                  // fx_cast_reg + its output register
    // range_coords: input, sums, casts (xp .. b1 at XY_AT), products, the two-cycle sum
    // of k, its cast (k at K_AT), products, sums, casts
    localparam integer XY_AT = 2 + CAST_LAT;                        // 4
    localparam integer K_AT = XY_AT + FX_MUL_LAT + 2 + CAST_LAT;    // 12
    localparam integer C_LAT = K_AT + FX_MUL_LAT + 1 + CAST_LAT;    // 19
    // range_products: products, the two-cycle sum of den (gv v_sq beside it) and casts
    // (gv den v_sq at GV_AT), num's difference and cast (NUM_AT), products, casts
    localparam integer GV_AT = FX_MUL_LAT + 2 + CAST_LAT;           // 8
    localparam integer NUM_AT = GV_AT + 1 + CAST_LAT;               // 11
    localparam integer P_LAT = GV_AT + FX_MUL_LAT + CAST_LAT;       // 14
    localparam integer DIV_FRONT = DIVIDER ? 14 : 1;  // PIPE = 2 / FRONT = 1
    localparam integer DIV_LAT = (DIVIDER ? 9 : RNG_W + 4) + DIV_FRONT;

    // host registers as two's complement values
    wire signed [CO_SW-1:0]  cx_v = `RFX_SX(cx_raw, CO_S);
    wire signed [CO_SW-1:0]  cy_v = `RFX_SX(cy_raw, CO_S);
    wire signed [FR_SW-1:0]  f_v = `RFX_SX(f_raw, FR_S);
    wire signed [KT_SW-1:0]  k3_v = `RFX_SX(k3_raw, KT_S);
    wire signed [KT_SW-1:0]  k4_v = `RFX_SX(k4_raw, KT_S);
    wire signed [KT_SW-1:0]  k5_v = `RFX_SX(k5_raw, KT_S);
    wire signed [TG2_SW-1:0] tg2_v = `RFX_SX(tg2_raw, TG2_S);
    wire signed [C1_SW-1:0]  te_v = `RFX_SX(te_raw, C1_S);
    wire signed [DEN_SW-1:0] dmin_v = `RFX_SX(dmin_raw, DEN_S);
    wire signed [RNG_SW-1:0] rmax_v = `RFX_SX(rmax_raw, RNG_S);

    // ---- +1: the input beat registered; pixel counters: column i and row j ----------------
    reg  [X_W-1:0] col_cnt;
    reg  [Y_W-1:0] row_cnt;
    wire [X_W-1:0] i_in = s_sof ? {X_W{1'b0}} : col_cnt;
    wire [Y_W-1:0] j_in = s_sof ? {Y_W{1'b0}} : row_cnt;
    reg            v1, sof1, eol1;
    reg [X_W-1:0]  i1;
    reg [Y_W-1:0]  j1;
    reg [S1_W-1:0] e1_s1_1, e2_s1_1;
    reg [EX_W-1:0] e1_ex_1, e2_ex_1;
    reg [S2_W-1:0] e1_s2_1, e2_s2_1;
    always @(posedge clk) begin
        if (rst) begin
            col_cnt <= {X_W{1'b0}};
            row_cnt <= {Y_W{1'b0}};
        end else if (s_valid) begin
            col_cnt <= s_eol ? {X_W{1'b0}} : i_in + 1'b1;
            row_cnt <= s_eol ? j_in + 1'b1 : j_in;
        end
        v1 <= s_valid & ~rst;
        {sof1, eol1, i1, j1} <= {s_sof, s_eol, i_in, j_in};
        {e1_s1_1, e2_s1_1, e1_ex_1, e2_ex_1, e1_s2_1, e2_s2_1}
            <= {e1_s1, e2_s1, e1_ex, e2_ex, e1_s2, e2_s2};
    end
    // valid (a shift register cleared by reset), sof, eol from +1 to the stages that use them
    reg  [C_LAT+P_LAT-3:0] v_sr;
    always @(posedge clk) v_sr <= rst ? {(C_LAT + P_LAT - 2){1'b0}} : {v_sr[C_LAT+P_LAT-4:0], v1};
    wire [1:0] se12, se21;
    fx_delay #(2, C_LAT - 2) d_se12 (clk, {sof1, eol1}, se12);
    fx_delay #(2, P_LAT) d_se21 (clk, se12, se21);
    wire [2:0] ctl12 = {v_sr[C_LAT-3], se12};
    wire [2:0] ctl21 = {v_sr[C_LAT+P_LAT-3], se21};

    // ---- +2: exact xp, yp, c1, a1, b1 ----------------------------------------------------
    localparam integer F_CO0 = `RFX_MAX(CO_F, 0);  // counters are integers
    localparam integer XPW = `RFX_MAX(X_W + 1 + F_CO0, CO_SW + F_CO0 - CO_F) + 1;
    localparam integer YPW = `RFX_MAX(Y_W + 1 + F_CO0, CO_SW + F_CO0 - CO_F) + 1;
    reg signed [XPW-1:0]   xp_x;
    reg signed [YPW-1:0]   yp_x;
    reg signed [S1_SW:0]   c1_x;
    reg signed [EX_SW:0]   a1_x;
    reg signed [S2_SW:0]   b1_x;
    always @(posedge clk) begin
        xp_x <= ($signed({1'b0, i1}) <<< F_CO0) - (cx_v <<< (F_CO0 - CO_F));
        yp_x <= ($signed({1'b0, j1}) <<< F_CO0) - (cy_v <<< (F_CO0 - CO_F));
        c1_x <= `RFX_SX(e1_s1_1, S1_S) - `RFX_SX(e2_s1_1, S1_S);
        a1_x <= `RFX_SX(e1_ex_1, EX_S) + `RFX_SX(e2_ex_1, EX_S);
        b1_x <= `RFX_SX(e1_s2_1, S2_S) + `RFX_SX(e2_s2_1, S2_S);
    end

    // ---- +3, +4: the casts xp, yp, c1, a1, b1 (rounded value at +3, overflow mode at +4) --
    wire [CO_W-1:0] xp_c, yp_c;
    wire [C1_W-1:0] c1_c;
    wire [GA_W-1:0] a1_c;
    wire [GB_W-1:0] b1_c;
    wire [12:0]     ovf_n;
    fx_cast_reg #(XPW, F_CO0, CO_W, CO_F, CO_S, CO_Q, CO_O) u_xp (clk, xp_x, xp_c, ovf_n[0]);
    fx_cast_reg #(YPW, F_CO0, CO_W, CO_F, CO_S, CO_Q, CO_O) u_yp (clk, yp_x, yp_c, ovf_n[1]);
    fx_cast_reg #(S1_SW + 1, S1_F, C1_W, C1_F, C1_S, C1_Q, C1_O) u_c1 (
        clk, c1_x, c1_c, ovf_n[2]);
    fx_cast_reg #(EX_SW + 1, EX_F + 1, GA_W, GA_F, GA_S, GA_Q, GA_O) u_a1 (
        clk, a1_x, a1_c, ovf_n[3]);
    fx_cast_reg #(S2_SW + 1, S2_F + 1, GB_W, GB_F, GB_S, GB_Q, GB_O) u_b1 (
        clk, b1_x, b1_c, ovf_n[4]);
    reg [CO_W-1:0] xp4, yp4;
    reg [C1_W-1:0] c1_4;
    reg [GA_W-1:0] a1_4;
    reg [GB_W-1:0] b1_4;
    reg [4:0]      ovf4;
    always @(posedge clk) begin
        {xp4, yp4, c1_4, a1_4, b1_4} <= {xp_c, yp_c, c1_c, a1_c, b1_c};
        ovf4 <= ovf_n[4:0];
    end

    // ---- +5 .. +12: k_r = cast(M_r0 + M_r1 xp + M_r2 yp, k_rot), summed at FK fraction bits:
    // the products at +8, M_r0 + M_r1 xp at +9, + M_r2 yp at +10 (one carry chain a
    // cycle), the cast's rounded value at +11, k at +12
    localparam integer FK = `RFX_MAX(KM_F, KM_F + CO_F);
    localparam integer KPW = KM_SW + CO_SW;
    localparam integer KW = `RFX_MAX(KM_SW + FK - KM_F, KPW + FK - KM_F - CO_F) + 2;
    wire signed [CO_SW-1:0] xp4_s = `RFX_SX(xp4, CO_S);
    wire signed [CO_SW-1:0] yp4_s = `RFX_SX(yp4, CO_S);
    wire [3*KR_W-1:0] k_c;
    genvar r;
    generate
        for (r = 0; r < 3; r = r + 1) begin : g_k
            wire signed [KM_SW-1:0] m0 = `RFX_SX(m_raw[(3*r)*KM_W +: KM_W], KM_S);
            wire signed [KM_SW-1:0] m1 = `RFX_SX(m_raw[(3*r+1)*KM_W +: KM_W], KM_S);
            wire signed [KM_SW-1:0] m2 = `RFX_SX(m_raw[(3*r+2)*KM_W +: KM_W], KM_S);
            wire signed [KPW-1:0] m1x, m2y;
            fx_mul_pipe #(KM_SW, CO_SW, 1) u_m1x (clk, m1, xp4_s, m1x);
            fx_mul_pipe #(KM_SW, CO_SW, 1) u_m2y (clk, m2, yp4_s, m2y);
            reg signed [KW-1:0]  k_a, k_x;  // +9, +10
            reg signed [KPW-1:0] m2y_9;
            always @(posedge clk) begin
                k_a <= (m0 <<< (FK - KM_F)) + (m1x <<< (FK - KM_F - CO_F));
                m2y_9 <= m2y;
                k_x <= k_a + (m2y_9 <<< (FK - KM_F - CO_F));
            end
            fx_cast_reg #(KW, FK, KR_W, KR_F, KR_S, KR_Q, KR_O) u_k (
                clk, k_x, k_c[r*KR_W +: KR_W], ovf_n[5 + r]);
        end
    endgenerate
    reg [3*KR_W-1:0] k12;
    reg [2:0]        ovf12;
    always @(posedge clk) {k12, ovf12} <= {k_c, ovf_n[7:5]};

    // ---- +13 .. +19: vx, vy, wx, wy, w0: products +16, sums +17, casts +18, +19 ----------------
    localparam integer FGV = `RFX_MAX(FR_F + KT_F, CO_F + KT_F);
    localparam integer VPW = `RFX_MAX(FR_SW + KT_SW + FGV - FR_F - KT_F,
                                      CO_SW + KT_SW + FGV - CO_F - KT_F) + 1;
    localparam integer FGW = `RFX_MAX(FR_F + KR_F, CO_F + KR_F);
    localparam integer WPW = `RFX_MAX(FR_SW + KR_SW + FGW - FR_F - KR_F,
                                      CO_SW + KR_SW + FGW - CO_F - KR_F) + 1;
    localparam integer F_W0 = `RFX_MAX(KR_F, 0);
    localparam integer W0W = `RFX_MAX(2 + F_W0, KR_SW + F_W0 - KR_F) + 1;
    wire [CO_W-1:0] xp12, yp12;
    fx_delay #(2 * CO_W, K_AT - XY_AT) d_xy12 (clk, {xp4, yp4}, {xp12, yp12});
    wire signed [CO_SW-1:0] xp12_s = `RFX_SX(xp12, CO_S);
    wire signed [CO_SW-1:0] yp12_s = `RFX_SX(yp12, CO_S);
    wire signed [KR_SW-1:0] k0_s = `RFX_SX(k12[0 +: KR_W], KR_S);
    wire signed [KR_SW-1:0] k1_s = `RFX_SX(k12[KR_W +: KR_W], KR_S);
    wire signed [KR_SW-1:0] k2_s = `RFX_SX(k12[2*KR_W +: KR_W], KR_S);
    wire signed [FR_SW+KT_SW-1:0] fk4, fk5;
    wire signed [CO_SW+KT_SW-1:0] xk3, yk3;
    wire signed [FR_SW+KR_SW-1:0] fk1, fk2;
    wire signed [CO_SW+KR_SW-1:0] xk0, yk0;
    fx_mul_pipe #(FR_SW, KT_SW, 1) u_fk4 (clk, f_v, k4_v, fk4);
    fx_mul_pipe #(FR_SW, KT_SW, 1) u_fk5 (clk, f_v, k5_v, fk5);
    fx_mul_pipe #(CO_SW, KT_SW, 1) u_xk3 (clk, xp12_s, k3_v, xk3);
    fx_mul_pipe #(CO_SW, KT_SW, 1) u_yk3 (clk, yp12_s, k3_v, yk3);
    fx_mul_pipe #(FR_SW, KR_SW, 1) u_fk1 (clk, f_v, k1_s, fk1);
    fx_mul_pipe #(FR_SW, KR_SW, 1) u_fk2 (clk, f_v, k2_s, fk2);
    fx_mul_pipe #(CO_SW, KR_SW, 1) u_xk0 (clk, xp12_s, k0_s, xk0);
    fx_mul_pipe #(CO_SW, KR_SW, 1) u_yk0 (clk, yp12_s, k0_s, yk0);
    wire [KR_W-1:0] k0_16;
    fx_delay #(KR_W, FX_MUL_LAT) d_k0 (clk, k12[0 +: KR_W], k0_16);
    wire signed [KR_SW-1:0] k0_16_s = `RFX_SX(k0_16, KR_S);
    reg signed [VPW-1:0] vx_x, vy_x;  // +17
    reg signed [WPW-1:0] wx_x, wy_x;
    reg signed [W0W-1:0] w0_x;
    always @(posedge clk) begin
        vx_x <= (fk4 <<< (FGV - FR_F - KT_F)) - (xk3 <<< (FGV - CO_F - KT_F));
        vy_x <= (fk5 <<< (FGV - FR_F - KT_F)) - (yk3 <<< (FGV - CO_F - KT_F));
        wx_x <= (fk1 <<< (FGW - FR_F - KR_F)) - (xk0 <<< (FGW - CO_F - KR_F));
        wy_x <= (fk2 <<< (FGW - FR_F - KR_F)) - (yk0 <<< (FGW - CO_F - KR_F));
        w0_x <= ($signed(3'sd1) <<< F_W0) + (k0_16_s <<< (F_W0 - KR_F));
    end
    wire [V_W-1:0] vx_c, vy_c;
    wire [W_W-1:0] wx_c, wy_c, w0_c;
    fx_cast_reg #(VPW, FGV, V_W, V_F, V_S, V_Q, V_O) u_vx (clk, vx_x, vx_c, ovf_n[8]);
    fx_cast_reg #(VPW, FGV, V_W, V_F, V_S, V_Q, V_O) u_vy (clk, vy_x, vy_c, ovf_n[9]);
    fx_cast_reg #(WPW, FGW, W_W, W_F, W_S, W_Q, W_O) u_wx (clk, wx_x, wx_c, ovf_n[10]);
    fx_cast_reg #(WPW, FGW, W_W, W_F, W_S, W_Q, W_O) u_wy (clk, wy_x, wy_c, ovf_n[11]);
    fx_cast_reg #(W0W, F_W0, W_W, W_F, W_S, W_Q, W_O) u_w0 (clk, w0_x, w0_c, ovf_n[12]);

    // ---- +19: the range_coords taps, each cast's value from its own cycle ---------------------
    localparam integer G3W = 2 * CO_W + C1_W + GA_W + GB_W + 5;
    localparam integer G8W = 3 * KR_W + 3;
    wire [G3W-1:0] g3_18;
    wire [G8W-1:0] g8_18;
    fx_delay #(G3W, C_LAT - 1 - XY_AT) d_g3 (clk, {xp4, yp4, c1_4, a1_4, b1_4, ovf4}, g3_18);
    fx_delay #(G8W, C_LAT - 1 - K_AT) d_g8 (clk, {k12, ovf12}, g8_18);
    always @(posedge clk) begin
        c_valid <= ctl12[2] & ~rst;
        {xp, yp, c1, a1, b1} <= g3_18[G3W-1:5];
        {k2, k1, k0} <= g8_18[G8W-1:3];
        {vx, vy, wx, wy, w0} <= {vx_c, vy_c, wx_c, wy_c, w0_c};
        ovf_c <= {ovf_n[12:8], g8_18[2:0], g3_18[4:0]};
    end

    // ---- after the range_coords taps (+0): products +4; the sums of gv, v_sq and
    // awx + bwy at +5, den = awx + bwy - cw0 at +6 (gv, v_sq wait beside it); the casts'
    // rounded values +7, gv den v_sq +8; num: k3 c1 - gv +9, its casts +10, +11; g_sq,
    // g_thr: products +12, casts +13, +14 = the range_products taps
    localparam integer FGVS = `RFX_MAX(GA_F + V_F, GB_F + V_F);
    localparam integer GVW = `RFX_MAX(GA_SW + V_SW + FGVS - GA_F - V_F,
                                      GB_SW + V_SW + FGVS - GB_F - V_F) + 1;
    localparam integer FDS = `RFX_MAX(`RFX_MAX(GA_F + W_F, GB_F + W_F), C1_F + W_F);
    localparam integer DSW = `RFX_MAX(`RFX_MAX(GA_SW + W_SW + FDS - GA_F - W_F,
                                               GB_SW + W_SW + FDS - GB_F - W_F),
                                      C1_SW + W_SW + FDS - C1_F - W_F) + 2;
    wire signed [GA_SW-1:0] a1_s = `RFX_SX(a1, GA_S);
    wire signed [GB_SW-1:0] b1_s = `RFX_SX(b1, GB_S);
    wire signed [C1_SW-1:0] c1_s = `RFX_SX(c1, C1_S);
    wire signed [V_SW-1:0]  vx_s = `RFX_SX(vx, V_S), vy_s = `RFX_SX(vy, V_S);
    wire signed [W_SW-1:0]  wx_s = `RFX_SX(wx, W_S), wy_s = `RFX_SX(wy, W_S);
    wire signed [W_SW-1:0]  w0_s = `RFX_SX(w0, W_S);
    wire signed [GA_SW+V_SW-1:0] avx;
    wire signed [GB_SW+V_SW-1:0] bvy;
    wire signed [GA_SW+W_SW-1:0] awx;
    wire signed [GB_SW+W_SW-1:0] bwy;
    wire signed [C1_SW+W_SW-1:0] cw0;
    wire signed [2*V_SW-1:0]     vx2, vy2;
    wire signed [KT_SW+C1_SW-1:0] k3c1;
    fx_mul_pipe #(GA_SW, V_SW, 1) u_avx (clk, a1_s, vx_s, avx);
    fx_mul_pipe #(GB_SW, V_SW, 1) u_bvy (clk, b1_s, vy_s, bvy);
    fx_mul_pipe #(GA_SW, W_SW, 1) u_awx (clk, a1_s, wx_s, awx);
    fx_mul_pipe #(GB_SW, W_SW, 1) u_bwy (clk, b1_s, wy_s, bwy);
    fx_mul_pipe #(C1_SW, W_SW, 1) u_cw0 (clk, c1_s, w0_s, cw0);
    fx_mul_pipe #(V_SW, V_SW, 1) u_vx2 (clk, vx_s, vx_s, vx2);
    fx_mul_pipe #(V_SW, V_SW, 1) u_vy2 (clk, vy_s, vy_s, vy2);
    fx_mul_pipe #(KT_SW, C1_SW, 1) u_k3c1 (clk, k3_v, c1_s, k3c1);
    reg signed [GVW-1:0]         gv_a, gv_x;   // +5, +6
    reg signed [DSW-1:0]         den_a, den_x;
    reg signed [C1_SW+W_SW-1:0]  cw0_5;
    reg signed [2*V_SW:0]        vsq_a, vsq_x;
    always @(posedge clk) begin
        gv_a <= (avx <<< (FGVS - GA_F - V_F)) + (bvy <<< (FGVS - GB_F - V_F));
        den_a <= (awx <<< (FDS - GA_F - W_F)) + (bwy <<< (FDS - GB_F - W_F));
        cw0_5 <= cw0;
        vsq_a <= vx2 + vy2;
        gv_x <= gv_a;
        den_x <= den_a - (cw0_5 <<< (FDS - C1_F - W_F));
        vsq_x <= vsq_a;
    end
    wire [GV_W-1:0]  gv_c;
    wire [DEN_W-1:0] den_c;
    wire [VSQ_W-1:0] vsq_c;
    wire [5:0]       ovfp_n;   // bit order gv, num, den, v_sq, g_sq, g_thr
    fx_cast_reg #(GVW, FGVS, GV_W, GV_F, GV_S, GV_Q, GV_O) u_gv (clk, gv_x, gv_c, ovfp_n[0]);
    fx_cast_reg #(DSW, FDS, DEN_W, DEN_F, DEN_S, DEN_Q, DEN_O) u_den (
        clk, den_x, den_c, ovfp_n[2]);
    fx_cast_reg #(2 * V_SW + 1, 2 * V_F, VSQ_W, VSQ_F, VSQ_S, VSQ_Q, VSQ_O) u_vsq (
        clk, vsq_x, vsq_c, ovfp_n[3]);
    reg [GV_W-1:0]  gv8;
    reg [DEN_W-1:0] den8;
    reg [VSQ_W-1:0] vsq8;
    reg [2:0]       ovf8;   // gv, den, v_sq
    always @(posedge clk) begin
        {gv8, den8, vsq8} <= {gv_c, den_c, vsq_c};
        ovf8 <= {ovfp_n[3], ovfp_n[2], ovfp_n[0]};
    end
    // num = cast(k3 c1 - gv): +9 exact, +10, +11 cast
    localparam integer FNS = `RFX_MAX(KT_F + C1_F, GV_F);
    localparam integer NSW = `RFX_MAX(KT_SW + C1_SW + FNS - KT_F - C1_F, GV_SW + FNS - GV_F) + 1;
    wire signed [GV_SW-1:0]  gv8_s = `RFX_SX(gv8, GV_S);
    wire signed [VSQ_SW-1:0] vsq8_s = `RFX_SX(vsq8, VSQ_S);
    wire signed [KT_SW+C1_SW-1:0] k3c1_8;
    fx_delay #(KT_SW + C1_SW, GV_AT - FX_MUL_LAT) d_k3c1 (clk, k3c1, k3c1_8);
    reg signed [NSW-1:0] num_x;
    always @(posedge clk)
        num_x <= (k3c1_8 <<< (FNS - KT_F - C1_F)) - (gv8_s <<< (FNS - GV_F));
    wire [NUM_W-1:0] num_c;
    fx_cast_reg #(NSW, FNS, NUM_W, NUM_F, NUM_S, NUM_Q, NUM_O) u_num (
        clk, num_x, num_c, ovfp_n[1]);
    reg [NUM_W-1:0] num11;
    reg             ovf11;
    always @(posedge clk) {num11, ovf11} <= {num_c, ovfp_n[1]};
    // g_sq = cast(gv^2), g_thr = cast(TG2 v_sq): +12 products, +13, +14 casts
    wire signed [2*GV_SW-1:0]       gsq_x;
    wire signed [TG2_SW+VSQ_SW-1:0] gthr_x;
    fx_mul_pipe #(GV_SW, GV_SW, 1) u_gsq (clk, gv8_s, gv8_s, gsq_x);
    fx_mul_pipe #(TG2_SW, VSQ_SW, 1) u_gthr (clk, tg2_v, vsq8_s, gthr_x);
    wire [GSQ_W-1:0] gsq_c, gthr_c;
    fx_cast_reg #(2 * GV_SW, 2 * GV_F, GSQ_W, GSQ_F, GSQ_S, GSQ_Q, GSQ_O) u_gsq_c (
        clk, gsq_x, gsq_c, ovfp_n[4]);
    fx_cast_reg #(TG2_SW + VSQ_SW, TG2_F + VSQ_F, GSQ_W, GSQ_F, GSQ_S, GSQ_Q, GSQ_O) u_gthr_c (
        clk, gthr_x, gthr_c, ovfp_n[5]);
    localparam integer G8PW = GV_W + DEN_W + VSQ_W + 3;
    wire [G8PW-1:0]     g8_13;
    wire [NUM_W:0]      g11_13;
    fx_delay #(G8PW, P_LAT - 1 - GV_AT) d_g8p (clk, {gv8, den8, vsq8, ovf8}, g8_13);
    fx_delay #(NUM_W + 1, P_LAT - 1 - NUM_AT) d_g11 (clk, {num11, ovf11}, g11_13);
    reg p_sof, p_eol;
    always @(posedge clk) begin
        p_valid <= ctl21[2] & ~rst;
        {p_sof, p_eol} <= ctl21[1:0];
        {gv, den, v_sq} <= g8_13[G8PW-1:3];
        num <= g11_13[NUM_W:1];
        {g_sq, g_thr} <= {gsq_c, gthr_c};
        ovf_p <= {ovfp_n[5], ovfp_n[4], g8_13[2], g8_13[1], g11_13[0], g8_13[0]};
    end

    // ---- the divider's front end (+1 after the range_products taps): num / den where
    // |den| >= DMIN and den != 0, else 0 / 1. Its flags are formed from earlier registers
    // of the same values, one carry chain a cycle, and wait beside the pipeline: |den| and
    // den != 0 at +9, den_ok at +10 (from den at +8); |c1| at +1, |c1| >= T_E at +2 (from
    // the c1 tap); the operand select at +15 then only multiplexes.
    localparam integer DVW = `RFX_MAX(DEN_SW, DEN_F + 2);  // holds 1.0 = 2^DEN_F
    wire signed [NUM_SW-1:0] num_s = `RFX_SX(num, NUM_S);
    wire signed [DEN_SW-1:0] den_s = `RFX_SX(den, DEN_S);
    wire signed [DEN_SW-1:0] den8_s = `RFX_SX(den8, DEN_S);
    reg  signed [DEN_SW:0]   den_abs9;
    reg                      den_nz9, den_ok10, c1_ok2;
    reg  signed [C1_SW:0]    c1_abs1;
    always @(posedge clk) begin
        den_abs9 <= den8_s[DEN_SW-1] ? -den8_s : den8_s;
        den_nz9 <= den8_s != 0;
        den_ok10 <= (den_abs9 >= dmin_v) && den_nz9;
        c1_abs1 <= c1_s < 0 ? -c1_s : c1_s;
        c1_ok2 <= c1_abs1 >= te_v;
    end
    wire den_ok, te_ok_q;  // den_ok with the range_products taps; te_ok beside div_n
    fx_delay #(1, P_LAT - 10) d_den_ok (clk, den_ok10, den_ok);
    fx_delay #(1, P_LAT - 1) d_te_ok (clk, c1_ok2, te_ok_q);
    reg signed [NUM_SW-1:0] div_n;
    reg signed [DVW-1:0]    div_d;
    reg                     dv_valid, dv_sof, dv_eol, g_ok, den_ok_r;
    always @(posedge clk) begin
        div_n <= den_ok ? num_s : {NUM_SW{1'b0}};
        div_d <= den_ok ? den_s : ($signed({{(DVW-1){1'b0}}, 1'b1}) <<< DEN_F);
        dv_valid <= p_valid & ~rst;
        {dv_sof, dv_eol} <= {p_sof, p_eol};
        g_ok <= `RFX_SX(g_sq, GSQ_S) >= `RFX_SX(g_thr, GSQ_S);
        den_ok_r <= den_ok;
    end
    wire [RNG_W-1:0] rq;
    wire             rq_ovf;
    generate
        if (DIVIDER == 0) begin : g_restoring
            fx_div_restoring #(NUM_SW, NUM_F, DVW, DEN_F, RNG_W, RNG_F, RNG_S, RNG_Q, RNG_O,
                               DIV_FRONT) u_div (
                .clk(clk), .n(div_n), .d(div_d), .y(rq), .ovf(rq_ovf));
        end else begin : g_reciprocal
            fx_div_reciprocal #(NUM_SW, NUM_F, DVW, DEN_F, RNG_W, RNG_F, RNG_S, RNG_Q, RNG_O,
                                RECIP_L, RECIP_R, ROM_FILE, 2) u_div (
                .clk(clk), .n(div_n), .d(div_d), .y(rq), .ovf(rq_ovf));
        end
    endgenerate
    // the flags of the thresholds travel beside the divider
    reg [DIV_LAT-1:0]   valid_d;
    always @(posedge clk) valid_d <= rst ? {DIV_LAT{1'b0}} : {valid_d[DIV_LAT-2:0], dv_valid};
    wire [4:0] flags_q;
    fx_delay #(5, DIV_LAT) d_flags (clk, {dv_sof, dv_eol, te_ok_q, g_ok, den_ok_r}, flags_q);
    assign q_valid = valid_d[DIV_LAT-1];
    assign range_q = rq;
    assign ovf_q = rq_ovf;

    // ---- threshold stage: valid and the range output ----------------------------------------
    wire signed [RNG_SW-1:0] rq_s = `RFX_SX(rq, RNG_S);
    wire ok = flags_q[2] & flags_q[1] & flags_q[0] & ~rq_ovf & (rq_s > 0) & (rq_s <= rmax_v);
    always @(posedge clk) begin
        m_valid <= q_valid & ~rst;
        {m_sof, m_eol} <= flags_q[4:3];
        valid <= ok;
        range <= ok ? rq : rmax_raw;
    end
`undef RFX_SX
`undef RFX_MAX
endmodule
