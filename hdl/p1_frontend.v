// p1_frontend: the per-stream front end of rangefx P1, one pixel per clock
// (docs/p1_datapath.md steps 1-5): input cast, bias, row filter, column filter, and the
// x-derivative of the variant (paper: the divider s1 r2 / r1, restoring or reciprocal;
// consistent: a second column filter on r2 with its own line buffer).
//
// Cycle of each tap after its pixel's input beat at cycle t (rtl_model/p1/model.py
// stage_latencies; every tap is registered, each stage has its own valid):
//   t+1 input register x = cast(pixel, pix_in), column counter, first-row flag
//   t+2 bias_in                                            (bias_v)
//   t+3 row filter loop: prod = C (b - p), p_next, one state register (POLE_K >= 0:
//       C = 2^-k, the loop is one sum and the cast's overflow mode, no multiplier)
//   t+4 row_r1, row_r2, row_state                          (row_v)
//   t+7 col_s1, col_s2, col_state (p1_colfilt: line buffer read issued at t+3, its data
//       out registered at t+4; product, casts);
//       consistent: col2_state, ex = col2_out beside them (x-derivative latency 0)
//   paper: t+11 N = s1 r2 (fx_mul_pipe IREG, 4 stages), t+11+DIV_LAT ex = div_quot (ex_v)
// The stream outputs E_hat = s1, ex, ey = s2 leave together, aligned with ex (out_*), for
// the range stage (p1_range) or the frame store.
//
// Input: AXI4-Stream video without back-pressure (s_valid, s_data, s_sof = TUSER,
// s_eol = TLAST). A line longer than MAX_WIDTH pixels sets the sticky `line_too_long`
// and its extra pixels never reach the line buffers. Overflow counters (32 bits, from
// reset) count every cast whose overflow mode acted, per signal, as the model counts them.
// Formats: each signal's <NAME>_W, _F, _S (signed), _Q (quantisation), _O (overflow):
// PIX pix_in, BREG bias_reg, POLE pole_coef, B bias_in, P row_state, R1 row_r1, R2 row_r2,
// Q col_state, S1 col_s1, S2 col_s2, Q2 col2_state, X2 col2_out, DQ div_quot.
`timescale 1ns / 1ps
module p1_frontend #(
    parameter integer MAX_WIDTH = 1024,
    parameter integer ADDR_W = 11,
    parameter integer CONSISTENT = 0,
    parameter integer INIT_FIRST = 1,
    parameter integer DIVIDER = 1,            // paper variant: 0 restoring, 1 reciprocal
    parameter integer RECIP_L = 8,
    parameter integer RECIP_R = 20,
    parameter ROM_FILE = "recip_rom.mem",
    parameter integer POLE_K = -1,            // -1: C from pole_raw; k >= 0: C = 2^-k, a shift
`include "p1_frontend_params.vh"
    // derived: the x-derivative's format and the stage latencies
    parameter integer EX_W = CONSISTENT ? X2_W : DQ_W,
    parameter integer DIV_LAT = DIVIDER ? 9 + 14 : DQ_W + 4 + 1,  // PIPE = 2 / FRONT
    parameter integer EX_LAT = CONSISTENT ? 0 : 4 + DIV_LAT
) (
    input  wire              clk,
    input  wire              rst,
    input  wire [POLE_W-1:0] pole_raw,
    input  wire [BREG_W-1:0] bias_raw,
    input  wire              s_valid,
    input  wire [PIX_W-1:0]  s_data,
    input  wire              s_sof,
    input  wire              s_eol,
    // taps, each with its stage's valid
    output reg               bias_v,
    output reg  [B_W-1:0]    bias_in,
    output reg               row_v,
    output reg  [P_W-1:0]    row_state,
    output reg  [R1_W-1:0]   row_r1,
    output reg  [R2_W-1:0]   row_r2,
    output wire              col_v,
    output wire [Q_W-1:0]    col_state,
    output wire [S1_W-1:0]   col_s1,
    output wire [S2_W-1:0]   col_s2,
    output wire [Q2_W-1:0]   col2_state,
    output wire              ex_v,
    output wire [EX_W-1:0]   ex,
    // stream outputs E_hat, ex, ey, aligned with ex
    output wire              out_valid,
    output wire              out_sof,
    output wire              out_eol,
    output wire [S1_W-1:0]   out_e,
    output wire [EX_W-1:0]   out_ex,
    output wire [S2_W-1:0]   out_ey,
    output reg               line_too_long,
    // overflow counts per signal
    output reg  [31:0]       ovf_pix_in,
    output reg  [31:0]       ovf_bias_in,
    output reg  [31:0]       ovf_row_state,
    output reg  [31:0]       ovf_row_r1,
    output reg  [31:0]       ovf_row_r2,
    output reg  [31:0]       ovf_col_state,
    output reg  [31:0]       ovf_col_s1,
    output reg  [31:0]       ovf_col_s2,
    output reg  [31:0]       ovf_col2_state,
    output reg  [31:0]       ovf_col2_out,
    output reg  [31:0]       ovf_div_quot
);
    localparam integer FX = (PIX_F > BREG_F) ? PIX_F : BREG_F;
    localparam integer XB = ((PIX_W + FX - PIX_F > BREG_W + FX - BREG_F)
                             ? PIX_W + FX - PIX_F : BREG_W + FX - BREG_F) + 2;
    localparam integer FE = (B_F > P_F) ? B_F : P_F;          // row filter: b - p aligned
    localparam integer FP = POLE_F + FE;                      // prod
    localparam integer FS = (P_F > FP) ? P_F : FP;            // p + prod
    localparam integer EB = B_W + 1 + FE - B_F;
    localparam integer EP = P_W + 1 + FE - P_F;
    localparam integer DW = ((EB > EP) ? EB : EP) + 1;
    localparam integer PW = POLE_W + 1 + DW;
    localparam integer SQ = P_W + 1 + FS - P_F;
    localparam integer SP = PW + FS - FP;
    localparam integer SW = ((SQ > SP) ? SQ : SP) + 1;
    localparam integer NW = S1_W + R2_W + 2;                  // paper: N = s1 r2

    // ---- t+1: input register, column counter ------------------------------------------
    reg  [ADDR_W:0] col_cnt;                  // one bit more than an address: overlong lines
    reg             in_first_row;
    wire [ADDR_W:0] col_in = s_sof ? {(ADDR_W + 1){1'b0}} : col_cnt;
    wire            row0_in = s_sof ? 1'b1 : in_first_row;
    wire [PIX_W-1:0] x_next;
    wire             ovf_x;
    fx_cast_sized #(PIX_W + 1, 0, PIX_W, PIX_F, PIX_S, PIX_Q, PIX_O) c_pix (
        .x({(PIX_S != 0) & s_data[PIX_W-1], s_data}), .y(x_next), .ovf(ovf_x));
    reg [PIX_W-1:0]  x1;
    reg              v1, sof1, eol1, first1, ovfx1;
    reg [ADDR_W:0]   col1;
    always @(posedge clk) begin
        if (rst) begin
            v1 <= 1'b0;
            col_cnt <= {(ADDR_W + 1){1'b0}};
            in_first_row <= 1'b1;
            line_too_long <= 1'b0;
        end else begin
            v1 <= s_valid;
            if (s_valid) begin
                col_cnt <= s_eol ? {(ADDR_W + 1){1'b0}}
                         : (col_in < MAX_WIDTH ? col_in + 1'b1 : col_in);
                in_first_row <= s_eol ? 1'b0 : row0_in;
                if (col_in >= MAX_WIDTH) line_too_long <= 1'b1;
            end
        end
        x1 <= x_next;
        col1 <= col_in;
        first1 <= row0_in;
        sof1 <= s_sof;
        eol1 <= s_eol;
        ovfx1 <= ovf_x;
    end

    // ---- t+2: bias ----------------------------------------------------------------------
    wire signed [PIX_W:0]  x_s = {(PIX_S != 0) & x1[PIX_W-1], x1};
    wire signed [BREG_W:0] breg_s = {(BREG_S != 0) & bias_raw[BREG_W-1], bias_raw};
    wire signed [XB-1:0]   x_al = x_s;
    wire signed [XB-1:0]   breg_al = breg_s;
    wire signed [XB-1:0]   xb = (x_al <<< (FX - PIX_F)) + (breg_al <<< (FX - BREG_F));
    wire [B_W-1:0] b_next;
    wire           ovf_b;
    fx_cast_sized #(XB, FX, B_W, B_F, B_S, B_Q, B_O) c_bias (
        .x(xb), .y(b_next), .ovf(ovf_b));
    reg [ADDR_W:0] col2;
    reg            v2, sof2, eol2, first2, col0;   // col0: registered, out of the loop's mux
    always @(posedge clk) begin
        v2 <= rst ? 1'b0 : v1;
        bias_v <= rst ? 1'b0 : v1;
        bias_in <= b_next;
        col2 <= col1;
        col0 <= col1 == {(ADDR_W + 1){1'b0}};
        first2 <= first1;
        sof2 <= sof1;
        eol2 <= eol1;
    end

    // ---- t+3: the row filter's loop (one state register) -------------------------------
    wire signed [POLE_W:0] pole = {(POLE_S != 0) & pole_raw[POLE_W-1], pole_raw};
    reg  [P_W-1:0] p_reg;
    wire [P_W-1:0] p_init;
    wire           ovf_pinit;
    wire signed [B_W:0]  b_s = {(B_S != 0) & bias_in[B_W-1], bias_in};
    fx_cast_sized #(B_W + 1, B_F, P_W, P_F, P_S, P_Q, P_O) c_pinit (
        .x(b_s), .y(p_init), .ovf(ovf_pinit));
    wire [P_W-1:0] p_cur = col0 ? (INIT_FIRST ? p_init : {P_W{1'b0}}) : p_reg;
    wire signed [P_W:0]  p_s = {(P_S != 0) & p_cur[P_W-1], p_cur};
    wire signed [DW-1:0] b_al = b_s;
    wire signed [DW-1:0] p_al = p_s;
    wire signed [DW-1:0] diff = (b_al <<< (FE - B_F)) - (p_al <<< (FE - P_F));
    wire signed [PW-1:0] prod;      // C (b - p) at FP fraction bits, exact
    wire [P_W-1:0] p_next;
    wire           ovf_pnext;
    generate
        if (POLE_K < 0) begin : g_row_direct
            // the report's form: the pole register times (b - p), then p + prod
            assign prod = pole * diff;
            wire signed [SW-1:0] p_w = p_s;
            wire signed [SW-1:0] prod_w = prod;
            wire signed [SW-1:0] pre = (p_w <<< (FS - P_F)) + (prod_w <<< (FS - FP));
            fx_cast_sized #(SW, FS, P_W, P_F, P_S, P_Q, P_O) c_pnext (
                .x(pre), .y(p_next), .ovf(ovf_pnext));
        end else begin : g_row_shift
            // C = 2^-K: the same exact values without a multiplier. The loop computes
            // p + (b - p) 2^-K = (p (2^K - 1) + b) 2^-K as one sum at FE + K fraction bits;
            // a RND cast takes its half LSB from b's zero low bits (an OR, no carry) and
            // keeps only the floor and the overflow mode in the loop.
            assign prod = diff <<< (POLE_F - POLE_K);
            localparam integer FK = FE + POLE_K;
            localparam integer KW = DW + POLE_K + 2;
            localparam integer SHR = FK - P_F;                       // bits the cast drops
            localparam integer FOLD = (P_Q == 2 && SHR > 0 && B_F <= P_F) ? 1 : 0;
            wire signed [KW-1:0] pk = p_al <<< (FE - P_F);
            wire signed [KW-1:0] bk0 = b_al <<< (FE - B_F);
            wire signed [KW-1:0] half = FOLD ? ({{(KW-1){1'b0}}, 1'b1} <<< (SHR - 1)) : 0;
            wire signed [KW-1:0] bk = bk0 | half;
            wire signed [KW-1:0] pre = (POLE_K == 1) ? pk + bk : (pk <<< POLE_K) - pk + bk;
            fx_cast_sized #(KW, FK, P_W, P_F, P_S, FOLD ? 0 : P_Q, P_O) c_pnext (
                .x(pre), .y(p_next), .ovf(ovf_pnext));
        end
    endgenerate
    reg signed [PW-1:0] prod3;
    reg [P_W-1:0]  p3, pn3;
    reg [ADDR_W:0] col3;
    reg            v3, sof3, eol3, first3, ovfp3, ovfpi3;
    always @(posedge clk) begin
        if (v2) p_reg <= p_next;
        v3 <= rst ? 1'b0 : v2;
        prod3 <= prod;
        p3 <= p_cur;
        pn3 <= p_next;
        ovfp3 <= ovf_pnext;
        ovfpi3 <= col0 && (INIT_FIRST != 0) && ovf_pinit;
        col3 <= col2;
        first3 <= first2;
        sof3 <= sof2;
        eol3 <= eol2;
    end

    // ---- t+4: row filter outputs ----------------------------------------------------------
    wire [R2_W-1:0] r2_next;
    wire [R1_W-1:0] r1_next;
    wire            ovf_r1, ovf_r2;
    fx_cast_sized #(PW, FP, R2_W, R2_F, R2_S, R2_Q, R2_O) c_r2 (
        .x(prod3), .y(r2_next), .ovf(ovf_r2));
    wire signed [P_W:0]   p3_s = {(P_S != 0) & p3[P_W-1], p3};
    wire signed [P_W:0]   pn3_s = {(P_S != 0) & pn3[P_W-1], pn3};
    wire signed [P_W+1:0] psum = p3_s + pn3_s;
    generate
        if (CONSISTENT != 0) begin : g_r1_centred
            fx_cast_sized #(P_W + 2, P_F + 1, R1_W, R1_F, R1_S, R1_Q, R1_O) c_r1 (
                .x(psum), .y(r1_next), .ovf(ovf_r1));
        end else begin : g_r1_paper
            fx_cast_sized #(P_W + 1, P_F, R1_W, R1_F, R1_S, R1_Q, R1_O) c_r1 (
                .x(p3_s), .y(r1_next), .ovf(ovf_r1));
        end
    endgenerate
    reg [ADDR_W:0] col4;
    reg            sof4, eol4, first4;
    always @(posedge clk) begin
        row_v <= rst ? 1'b0 : v3;
        row_state <= pn3;
        row_r1 <= r1_next;
        row_r2 <= r2_next;
        col4 <= col3;
        first4 <= first3;
        sof4 <= sof3;
        eol4 <= eol3;
    end

    // ---- t+4 .. t+7: column filter(s), their line buffer reads issued at t+3 ------------
    // a column beyond MAX_WIDTH is mapped out of the line buffers' range
    wire [ADDR_W-1:0] lb_col = col4[ADDR_W] ? {ADDR_W{1'b1}} : col4[ADDR_W-1:0];
    wire [ADDR_W-1:0] rd_col = col3[ADDR_W] ? {ADDR_W{1'b1}} : col3[ADDR_W-1:0];
    wire [1:0] ovf_q, ovf_q2;
    wire       ovf_s1, ovf_s2, ovf_x2, unused_ovf;
    wire [S2_W-1:0] unused_s2;
    p1_colfilt #(
        .MAX_WIDTH(MAX_WIDTH), .ADDR_W(ADDR_W), .CENTRED(CONSISTENT), .INIT_FIRST(INIT_FIRST),
        .POLE_K(POLE_K), .POLE_W(POLE_W), .POLE_F(POLE_F), .POLE_S(POLE_S),
        .R_W(R1_W), .R_F(R1_F), .R_S(R1_S),
        .ST_W(Q_W), .ST_F(Q_F), .ST_S(Q_S), .ST_Q(Q_Q), .ST_O(Q_O),
        .S1_W(S1_W), .S1_F(S1_F), .S1_S(S1_S), .S1_Q(S1_Q), .S1_O(S1_O),
        .S2_W(S2_W), .S2_F(S2_F), .S2_S(S2_S), .S2_Q(S2_Q), .S2_O(S2_O)
    ) u_col (
        .clk(clk), .rst(rst), .pole_raw(pole_raw), .rd_en(v3), .rd_col(rd_col),
        .in_valid(row_v), .col(lb_col), .first_row(first4), .r(row_r1), .q_next(col_state), .s1(col_s1), .s2(col_s2),
        .ovf_st(ovf_q), .ovf_s1(ovf_s1), .ovf_s2(ovf_s2));
    // sideband t+4 -> t+7
    reg [2:0] v_d, sof_d, eol_d;
    always @(posedge clk) begin
        v_d <= rst ? 3'b000 : {v_d[1:0], row_v};
        sof_d <= {sof_d[1:0], sof4};
        eol_d <= {eol_d[1:0], eol4};
    end
    assign col_v = v_d[2];

    wire [EX_W-1:0] ex_w;
    generate
        if (CONSISTENT != 0) begin : g_col2
            p1_colfilt #(
                .MAX_WIDTH(MAX_WIDTH), .ADDR_W(ADDR_W), .CENTRED(1), .INIT_FIRST(INIT_FIRST),
                .POLE_K(POLE_K), .POLE_W(POLE_W), .POLE_F(POLE_F), .POLE_S(POLE_S),
                .R_W(R2_W), .R_F(R2_F), .R_S(R2_S),
                .ST_W(Q2_W), .ST_F(Q2_F), .ST_S(Q2_S), .ST_Q(Q2_Q), .ST_O(Q2_O),
                .S1_W(X2_W), .S1_F(X2_F), .S1_S(X2_S), .S1_Q(X2_Q), .S1_O(X2_O),
                .S2_W(S2_W), .S2_F(S2_F), .S2_S(S2_S), .S2_Q(S2_Q), .S2_O(S2_O)
            ) u_col2 (
                .clk(clk), .rst(rst), .pole_raw(pole_raw), .rd_en(v3), .rd_col(rd_col),
                .in_valid(row_v), .col(lb_col), .first_row(first4), .r(row_r2), .q_next(col2_state), .s1(ex_w),
                .s2(unused_s2), .ovf_st(ovf_q2), .ovf_s1(ovf_x2), .ovf_s2(unused_ovf));
        end else begin : g_no_col2
            assign col2_state = {Q2_W{1'b0}};
            assign ovf_q2 = 2'b00;
            assign ovf_x2 = 1'b0;
        end
    endgenerate

    // ---- paper: ex = s1 r2 / r1 --------------------------------------------------------
    wire ovf_dq_w;
    generate
        if (CONSISTENT == 0) begin : g_div
            reg [R1_W-1:0] r1_d [0:2];
            reg [R2_W-1:0] r2_d [0:2];
            always @(posedge clk) begin
                r1_d[0] <= row_r1; r1_d[1] <= r1_d[0]; r1_d[2] <= r1_d[1];
                r2_d[0] <= row_r2; r2_d[1] <= r2_d[0]; r2_d[2] <= r2_d[1];
            end
            wire signed [S1_W:0] s1_s = {(S1_S != 0) & col_s1[S1_W-1], col_s1};
            wire signed [R2_W:0] r2_s = {(R2_S != 0) & r2_d[2][R2_W-1], r2_d[2]};
            wire signed [NW-1:0] nprod;   // t+11 (FX_MUL_LAT = 4)
            fx_mul_pipe #(S1_W + 1, R2_W + 1, 1) u_n (clk, s1_s, r2_s, nprod);
            wire [R1_W-1:0] d9;
            fx_delay #(R1_W, 4) d_r1 (clk, r1_d[2], d9);
            wire signed [NW-1:0] n9 = nprod;
            // the divider takes two's complement operands: D = r1 with its sign bit
            wire signed [R1_W:0] d9_s = {(R1_S != 0) & d9[R1_W-1], d9};
            if (DIVIDER != 0) begin : g_recip
                fx_div_reciprocal #(
                    .N_W(NW), .N_F(S1_F + R2_F), .D_W(R1_W + 1), .D_F(R1_F),
                    .OUT_W(DQ_W), .OUT_F(DQ_F), .OUT_S(DQ_S), .QUANT(DQ_Q), .OVF(DQ_O),
                    .L(RECIP_L), .R(RECIP_R), .ROM_FILE(ROM_FILE), .PIPE(2)
                ) u_div (.clk(clk), .n(n9), .d(d9_s), .y(ex_w), .ovf(ovf_dq_w));
            end else begin : g_restoring
                fx_div_restoring #(
                    .N_W(NW), .N_F(S1_F + R2_F), .D_W(R1_W + 1), .D_F(R1_F),
                    .OUT_W(DQ_W), .OUT_F(DQ_F), .OUT_S(DQ_S), .QUANT(DQ_Q), .OVF(DQ_O),
                    .FRONT(1)
                ) u_div (.clk(clk), .n(n9), .d(d9_s), .y(ex_w), .ovf(ovf_dq_w));
            end
        end else begin : g_no_div
            assign ovf_dq_w = 1'b0;
        end
    endgenerate
    assign ex = ex_w;

    // ---- E_hat and ey delayed to ex: the stream outputs --------------------------------
    // (a LUT-RAM ring buffer, fx_delay; the valid bits are flip-flops cleared by reset)
    localparam integer XL = (EX_LAT > 0) ? EX_LAT : 1;
    reg [XL-1:0]   xv_d;
    always @(posedge clk) xv_d <= rst ? {XL{1'b0}} : {xv_d, col_v};
    wire [S1_W-1:0] e_x;
    wire [S2_W-1:0] ey_x;
    wire            sof_x, eol_x;
    fx_delay #(S1_W + S2_W + 2, EX_LAT) d_out (
        clk, {col_s1, col_s2, sof_d[2], eol_d[2]}, {e_x, ey_x, sof_x, eol_x});
    assign ex_v = (EX_LAT > 0) ? xv_d[XL-1] : col_v;
    assign out_valid = ex_v;
    assign {out_e, out_ey, out_sof, out_eol} = {e_x, ey_x, sof_x, eol_x};
    assign out_ex = ex_w;

    // ---- overflow counters ---------------------------------------------------------------
    // each flag is counted when its pixel's sample is valid at that stage
    reg ovfx2, ovfb2;
    always @(posedge clk) begin
        ovfx2 <= ovfx1;
        ovfb2 <= ovf_b;
    end
    wire [XL-1:0] dq_v = xv_d;   // the divider's output is valid with ex_v
    always @(posedge clk) begin
        if (rst) begin
            ovf_pix_in <= 0; ovf_bias_in <= 0; ovf_row_state <= 0; ovf_row_r1 <= 0;
            ovf_row_r2 <= 0; ovf_col_state <= 0; ovf_col_s1 <= 0; ovf_col_s2 <= 0;
            ovf_col2_state <= 0; ovf_col2_out <= 0; ovf_div_quot <= 0;
        end else begin
            if (bias_v) begin
                ovf_pix_in <= ovf_pix_in + ovfx2;
                ovf_bias_in <= ovf_bias_in + ovfb2;
            end
            if (v3) ovf_row_state <= ovf_row_state + ovfp3 + ovfpi3;
            if (v3) ovf_row_r1 <= ovf_row_r1 + ovf_r1;
            if (v3) ovf_row_r2 <= ovf_row_r2 + ovf_r2;
            ovf_col_state <= ovf_col_state + ovf_q[0] + ovf_q[1];
            ovf_col_s1 <= ovf_col_s1 + ovf_s1;
            ovf_col_s2 <= ovf_col_s2 + ovf_s2;
            ovf_col2_state <= ovf_col2_state + ovf_q2[0] + ovf_q2[1];
            ovf_col2_out <= ovf_col2_out + ovf_x2;
            if (CONSISTENT == 0 && dq_v[XL-1]) ovf_div_quot <= ovf_div_quot + ovf_dq_w;
        end
    end
endmodule
