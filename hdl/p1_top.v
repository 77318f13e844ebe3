// p1_top: rangefx P1 streams into the range stage, AXI4-Stream video in and out
// (TVALID, TDATA, TUSER = start of frame, TLAST = end of line; no back-pressure: P1
// takes one pixel per clock), one pixel per clock.
//
// MOTION = 0 (stereo): two synchronised inputs, s0_axis = E1 (left), s1_axis = E2
// (right), each through its own p1_frontend (fe0, fe1). Both must carry their beats in
// the same cycles (synchronised cameras, as the model assumes); a cycle where their
// TVALID, TUSER or TLAST differ sets the sticky `align_error`.
// MOTION = 1: one input s0_axis carrying consecutive frames through fe0; E1 is the
// previous frame's E_hat, ex, ey from the frame store (MAX_PIXELS words; read one cycle
// before the current pixel's front-end outputs leave, written with them: read before
// write), E2 the current frame's. The range stage's inputs are valid from the second
// frame on. A frame larger than MAX_PIXELS sets `frame_too_big` (extra pixels unstored).
//
// The range stage p1_range (u_range) takes the wires rs_*: both streams' E_hat, ex, ey
// of one pixel, at the front end's latency FE_LAT (t+7 consistent, t+11+DIV_LAT paper,
// after the input beat at t). m_axis carries its output, one beat per pixel:
// TDATA = {valid, range} (range: RNG_W bits, the range code or RMAX where invalid).
// The host registers (raw codes in their register formats) are ports, as p1_range's.
`timescale 1ns / 1ps
module p1_top #(
    parameter integer MOTION = 0,
    parameter integer MAX_WIDTH = 1024,
    parameter integer ADDR_W = 11,
    parameter integer MAX_PIXELS = 1024,
    parameter integer PADDR_W = 11,
    parameter integer CONSISTENT = 0,
    parameter integer INIT_FIRST = 1,
    parameter integer DIVIDER = 1,
    parameter integer RECIP_L = 8,
    parameter integer RECIP_R = 20,
    parameter ROM_FILE = "recip_rom.mem",
    parameter integer POLE_K = -1,      // filters: -1 multiply by pole_raw, k >= 0 shift by k
`include "p1_frontend_params.vh"
    // range stage (p1_range): counters, host registers, its signals
    parameter integer X_W = 10,    parameter integer Y_W = 10,
`include "p1_range_params.vh"
    ,
    parameter integer EX_W = CONSISTENT ? X2_W : DQ_W,
    parameter integer EX_F = CONSISTENT ? X2_F : DQ_F,
    parameter integer EX_S = CONSISTENT ? X2_S : DQ_S,
    parameter integer DIV_LAT = DIVIDER ? 9 + 14 : DQ_W + 4 + 1,
    parameter integer FE_LAT = CONSISTENT ? 7 : 11 + DIV_LAT,
    parameter integer SW = S1_W + EX_W + S2_W       // one stream's outputs (frame store)
) (
    input  wire              clk,
    input  wire              rst,
    input  wire [POLE_W-1:0] pole_raw,
    input  wire [BREG_W-1:0] bias_raw,
    input  wire [CO_W-1:0]   cx_raw,
    input  wire [CO_W-1:0]   cy_raw,
    input  wire [FR_W-1:0]   f_raw,
    input  wire [KT_W-1:0]   k3_raw,
    input  wire [KT_W-1:0]   k4_raw,
    input  wire [KT_W-1:0]   k5_raw,
    input  wire [9*KM_W-1:0] m_raw,
    input  wire [C1_W-1:0]   te_raw,
    input  wire [TG2_W-1:0]  tg2_raw,
    input  wire [DEN_W-1:0]  dmin_raw,
    input  wire [RNG_W-1:0]  rmax_raw,
    input  wire              s0_axis_tvalid,
    input  wire [PIX_W-1:0]  s0_axis_tdata,
    input  wire              s0_axis_tuser,
    input  wire              s0_axis_tlast,
    input  wire              s1_axis_tvalid,
    input  wire [PIX_W-1:0]  s1_axis_tdata,
    input  wire              s1_axis_tuser,
    input  wire              s1_axis_tlast,
    output wire              m_axis_tvalid,
    output wire [RNG_W:0]    m_axis_tdata,
    output wire              m_axis_tuser,
    output wire              m_axis_tlast,
    output reg               align_error,
    output reg               frame_too_big,
    output wire              line_too_long
);
    // E1 / E2 outputs of the front end(s), valid at FE_LAT
    wire              o0_valid, o0_sof, o0_eol;
    wire [S1_W-1:0]   o0_e;
    wire [EX_W-1:0]   o0_ex;
    wire [S2_W-1:0]   o0_ey;
    wire              ltl0, ltl1;

`define P1_FE_PARAMS \
        .MAX_WIDTH(MAX_WIDTH), .ADDR_W(ADDR_W), .CONSISTENT(CONSISTENT), \
        .INIT_FIRST(INIT_FIRST), .DIVIDER(DIVIDER), .RECIP_L(RECIP_L), .RECIP_R(RECIP_R), \
        .ROM_FILE(ROM_FILE), .POLE_K(POLE_K), \
        .PIX_W(PIX_W), .PIX_F(PIX_F), .PIX_S(PIX_S), .PIX_Q(PIX_Q), .PIX_O(PIX_O), \
        .BREG_W(BREG_W), .BREG_F(BREG_F), .BREG_S(BREG_S), \
        .POLE_W(POLE_W), .POLE_F(POLE_F), .POLE_S(POLE_S), \
        .B_W(B_W), .B_F(B_F), .B_S(B_S), .B_Q(B_Q), .B_O(B_O), \
        .P_W(P_W), .P_F(P_F), .P_S(P_S), .P_Q(P_Q), .P_O(P_O), \
        .R1_W(R1_W), .R1_F(R1_F), .R1_S(R1_S), .R1_Q(R1_Q), .R1_O(R1_O), \
        .R2_W(R2_W), .R2_F(R2_F), .R2_S(R2_S), .R2_Q(R2_Q), .R2_O(R2_O), \
        .Q_W(Q_W), .Q_F(Q_F), .Q_S(Q_S), .Q_Q(Q_Q), .Q_O(Q_O), \
        .S1_W(S1_W), .S1_F(S1_F), .S1_S(S1_S), .S1_Q(S1_Q), .S1_O(S1_O), \
        .S2_W(S2_W), .S2_F(S2_F), .S2_S(S2_S), .S2_Q(S2_Q), .S2_O(S2_O), \
        .Q2_W(Q2_W), .Q2_F(Q2_F), .Q2_S(Q2_S), .Q2_Q(Q2_Q), .Q2_O(Q2_O), \
        .X2_W(X2_W), .X2_F(X2_F), .X2_S(X2_S), .X2_Q(X2_Q), .X2_O(X2_O), \
        .DQ_W(DQ_W), .DQ_F(DQ_F), .DQ_S(DQ_S), .DQ_Q(DQ_Q), .DQ_O(DQ_O)

    p1_frontend #(`P1_FE_PARAMS) fe0 (
        .clk(clk), .rst(rst), .pole_raw(pole_raw), .bias_raw(bias_raw),
        .s_valid(s0_axis_tvalid), .s_data(s0_axis_tdata), .s_sof(s0_axis_tuser),
        .s_eol(s0_axis_tlast),
        .out_valid(o0_valid), .out_sof(o0_sof), .out_eol(o0_eol),
        .out_e(o0_e), .out_ex(o0_ex), .out_ey(o0_ey), .line_too_long(ltl0));

    // the range stage's inputs
    wire              rs_valid, rs_sof, rs_eol;
    wire [S1_W-1:0]   rs_e1, rs_e2;
    wire [EX_W-1:0]   rs_ex1, rs_ex2;
    wire [S2_W-1:0]   rs_ey1, rs_ey2;

    generate
        if (MOTION == 0) begin : g_stereo
            wire o1_valid, o1_sof, o1_eol;
            p1_frontend #(`P1_FE_PARAMS) fe1 (
                .clk(clk), .rst(rst), .pole_raw(pole_raw), .bias_raw(bias_raw),
                .s_valid(s1_axis_tvalid), .s_data(s1_axis_tdata), .s_sof(s1_axis_tuser),
                .s_eol(s1_axis_tlast),
                .out_valid(o1_valid), .out_sof(o1_sof), .out_eol(o1_eol),
                .out_e(rs_e2), .out_ex(rs_ex2), .out_ey(rs_ey2), .line_too_long(ltl1));
            always @(posedge clk) begin
                if (rst) align_error <= 1'b0;
                else if (s0_axis_tvalid != s1_axis_tvalid
                         || (s0_axis_tvalid && (s0_axis_tuser != s1_axis_tuser
                                                || s0_axis_tlast != s1_axis_tlast)))
                    align_error <= 1'b1;
                frame_too_big <= 1'b0;
            end
            assign rs_valid = o0_valid;
            assign rs_sof = o0_sof;
            assign rs_eol = o0_eol;
            assign rs_e1 = o0_e;
            assign rs_ex1 = o0_ex;
            assign rs_ey1 = o0_ey;
        end else begin : g_motion
            // pixel address of each input beat, delayed to one cycle before its outputs
            reg  [PADDR_W:0] pix_cnt;
            wire [PADDR_W:0] addr_in = s0_axis_tuser ? {(PADDR_W + 1){1'b0}} : pix_cnt;
            reg  [PADDR_W:0] addr_d [0:FE_LAT-1];
            integer k;
            always @(posedge clk) begin
                if (rst) begin
                    pix_cnt <= {(PADDR_W + 1){1'b0}};
                    frame_too_big <= 1'b0;
                end else if (s0_axis_tvalid) begin
                    pix_cnt <= (addr_in < MAX_PIXELS) ? addr_in + 1'b1 : addr_in;
                    if (addr_in >= MAX_PIXELS) frame_too_big <= 1'b1;
                end
                addr_d[0] <= addr_in;
                for (k = 1; k < FE_LAT; k = k + 1) addr_d[k] <= addr_d[k-1];
                align_error <= 1'b0;
            end
            // the frame store: {ey, ex, E_hat} per pixel
            reg [SW-1:0] store [0:MAX_PIXELS-1];
            reg [SW-1:0] prev;
            wire [PADDR_W:0] rd_addr = addr_d[FE_LAT-2];
            wire [PADDR_W:0] wr_addr = addr_d[FE_LAT-1];
            always @(posedge clk) begin
                if (rd_addr < MAX_PIXELS) prev <= store[rd_addr];
                if (o0_valid && wr_addr < MAX_PIXELS) store[wr_addr] <= {o0_ey, o0_ex, o0_e};
            end
            // the range stage sees a pixel once a previous frame was stored
            reg seen_frame, has_prev;
            always @(posedge clk) begin
                if (rst) begin
                    seen_frame <= 1'b0;
                    has_prev <= 1'b0;
                end else if (o0_valid && o0_sof) begin
                    seen_frame <= 1'b1;
                    has_prev <= seen_frame;
                end
            end
            assign ltl1 = 1'b0;
            assign rs_valid = o0_valid && (o0_sof ? seen_frame : has_prev);
            assign rs_sof = o0_sof;
            assign rs_eol = o0_eol;
            assign {rs_ey1, rs_ex1, rs_e1} = prev;
            assign rs_e2 = o0_e;
            assign rs_ex2 = o0_ex;
            assign rs_ey2 = o0_ey;
        end
    endgenerate
`undef P1_FE_PARAMS

    assign line_too_long = ltl0 | ltl1;
    // ---- the range stage ------------------------------------------------------------------
    wire rng_valid, rng_sof, rng_eol, rng_ok;
    wire [RNG_W-1:0] rng;
    p1_range #(
        .X_W(X_W), .Y_W(Y_W), .DIVIDER(DIVIDER), .RECIP_L(RECIP_L), .RECIP_R(RECIP_R),
        .ROM_FILE(ROM_FILE),
        .S1_W(S1_W), .S1_F(S1_F), .S1_S(S1_S), .EX_W(EX_W), .EX_F(EX_F), .EX_S(EX_S),
        .S2_W(S2_W), .S2_F(S2_F), .S2_S(S2_S),
        .FR_W(FR_W), .FR_F(FR_F), .FR_S(FR_S), .KT_W(KT_W), .KT_F(KT_F), .KT_S(KT_S),
        .KM_W(KM_W), .KM_F(KM_F), .KM_S(KM_S), .TG2_W(TG2_W), .TG2_F(TG2_F), .TG2_S(TG2_S),
        .CO_W(CO_W), .CO_F(CO_F), .CO_S(CO_S), .CO_Q(CO_Q), .CO_O(CO_O),
        .C1_W(C1_W), .C1_F(C1_F), .C1_S(C1_S), .C1_Q(C1_Q), .C1_O(C1_O),
        .GA_W(GA_W), .GA_F(GA_F), .GA_S(GA_S), .GA_Q(GA_Q), .GA_O(GA_O),
        .GB_W(GB_W), .GB_F(GB_F), .GB_S(GB_S), .GB_Q(GB_Q), .GB_O(GB_O),
        .KR_W(KR_W), .KR_F(KR_F), .KR_S(KR_S), .KR_Q(KR_Q), .KR_O(KR_O),
        .V_W(V_W), .V_F(V_F), .V_S(V_S), .V_Q(V_Q), .V_O(V_O),
        .W_W(W_W), .W_F(W_F), .W_S(W_S), .W_Q(W_Q), .W_O(W_O),
        .GV_W(GV_W), .GV_F(GV_F), .GV_S(GV_S), .GV_Q(GV_Q), .GV_O(GV_O),
        .NUM_W(NUM_W), .NUM_F(NUM_F), .NUM_S(NUM_S), .NUM_Q(NUM_Q), .NUM_O(NUM_O),
        .DEN_W(DEN_W), .DEN_F(DEN_F), .DEN_S(DEN_S), .DEN_Q(DEN_Q), .DEN_O(DEN_O),
        .RNG_W(RNG_W), .RNG_F(RNG_F), .RNG_S(RNG_S), .RNG_Q(RNG_Q), .RNG_O(RNG_O),
        .VSQ_W(VSQ_W), .VSQ_F(VSQ_F), .VSQ_S(VSQ_S), .VSQ_Q(VSQ_Q), .VSQ_O(VSQ_O),
        .GSQ_W(GSQ_W), .GSQ_F(GSQ_F), .GSQ_S(GSQ_S), .GSQ_Q(GSQ_Q), .GSQ_O(GSQ_O)
    ) u_range (
        .clk(clk), .rst(rst),
        .cx_raw(cx_raw), .cy_raw(cy_raw), .f_raw(f_raw), .k3_raw(k3_raw), .k4_raw(k4_raw),
        .k5_raw(k5_raw), .m_raw(m_raw), .te_raw(te_raw), .tg2_raw(tg2_raw),
        .dmin_raw(dmin_raw), .rmax_raw(rmax_raw),
        .s_valid(rs_valid), .s_sof(rs_sof), .s_eol(rs_eol),
        .e1_s1(rs_e1), .e1_ex(rs_ex1), .e1_s2(rs_ey1),
        .e2_s1(rs_e2), .e2_ex(rs_ex2), .e2_s2(rs_ey2),
        .m_valid(rng_valid), .m_sof(rng_sof), .m_eol(rng_eol), .valid(rng_ok), .range(rng));
    assign m_axis_tvalid = rng_valid;
    assign m_axis_tuser = rng_sof;
    assign m_axis_tlast = rng_eol;
    assign m_axis_tdata = {rng_ok, rng};
endmodule
