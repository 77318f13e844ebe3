// p1_rowcol: rangefx P1 bias -> row filter -> column filter, one stream, one pixel/clock.
//
// Bit-exact with docs/p1_datapath.md steps 1-3 for the signals bias_in, row_state,
// row_r1, row_r2, col_state, col_s1, col_s2 (formats and modes as parameters, each
// signal's <NAME>_W, _F, _S (signed), _Q (quantisation), _O (overflow); see fx_cast.v).
// Exact intermediates are carried in 64-bit two's complement, which the word-length
// config guarantees to hold them (rtl_model/config.py rejects formats that need more).
//
// Input: AXI4-Stream video without back-pressure (s_valid, s_data, s_sof = TUSER,
// s_eol = TLAST). Output: the seven taps of each pixel, 3 cycles after its input beat,
// with m_valid/m_sof/m_eol. The row filter state is a register; the column filter
// state lives in a line buffer memory (MAX_WIDTH words), read one stage before it is
// written back (read before write per column). The registers pole_raw and bias_raw hold
// the host's quantised pole C and bias B (formats POLE_*, BREG_*).
//   CONSISTENT = 1: r1 = cast((p + p_next) / 2), s1 = cast((q + q_next) / 2);
//   CONSISTENT = 0 (paper): r1 = cast(p), s1 = cast(q).
//   INIT_FIRST = 1: state at column 0 / row 0 is the first input; 0: zero.
`timescale 1ns / 1ps
module p1_rowcol #(
    parameter integer MAX_WIDTH = 1024,
    parameter integer ADDR_W = 10,
    parameter integer CONSISTENT = 0,
    parameter integer INIT_FIRST = 1,
    parameter integer PIX_W = 8,   parameter integer PIX_F = 0,  parameter integer PIX_S = 0,
    parameter integer PIX_Q = 0,   parameter integer PIX_O = 1,
    parameter integer BREG_W = 8,  parameter integer BREG_F = 2, parameter integer BREG_S = 0,
    parameter integer POLE_W = 17, parameter integer POLE_F = 16, parameter integer POLE_S = 0,
    parameter integer B_W = 10,    parameter integer B_F = 1,    parameter integer B_S = 0,
    parameter integer B_Q = 0,     parameter integer B_O = 1,
    parameter integer P_W = 20,    parameter integer P_F = 11,   parameter integer P_S = 0,
    parameter integer P_Q = 2,     parameter integer P_O = 1,
    parameter integer R1_W = 20,   parameter integer R1_F = 11,  parameter integer R1_S = 0,
    parameter integer R1_Q = 2,    parameter integer R1_O = 1,
    parameter integer R2_W = 20,   parameter integer R2_F = 10,  parameter integer R2_S = 1,
    parameter integer R2_Q = 2,    parameter integer R2_O = 1,
    parameter integer Q_W = 22,    parameter integer Q_F = 13,   parameter integer Q_S = 0,
    parameter integer Q_Q = 2,     parameter integer Q_O = 1,
    parameter integer S1_W = 20,   parameter integer S1_F = 11,  parameter integer S1_S = 0,
    parameter integer S1_Q = 2,    parameter integer S1_O = 1,
    parameter integer S2_W = 21,   parameter integer S2_F = 11,  parameter integer S2_S = 1,
    parameter integer S2_Q = 2,    parameter integer S2_O = 1
) (
    input  wire              clk,
    input  wire              rst,
    input  wire [POLE_W-1:0] pole_raw,
    input  wire [BREG_W-1:0] bias_raw,
    input  wire              s_valid,
    input  wire [PIX_W-1:0]  s_data,
    input  wire              s_sof,
    input  wire              s_eol,
    output reg               m_valid,
    output reg               m_sof,
    output reg               m_eol,
    output reg  [B_W-1:0]    bias_in,
    output reg  [P_W-1:0]    row_state,
    output reg  [R1_W-1:0]   row_r1,
    output reg  [R2_W-1:0]   row_r2,
    output reg  [Q_W-1:0]    col_state,
    output reg  [S1_W-1:0]   col_s1,
    output reg  [S2_W-1:0]   col_s2
);
    // sign- or zero-extension of a raw code to 64-bit two's complement
`define RFX_SX(v, W, S) $signed((S) ? {{(64-(W)){v[(W)-1]}}, v} : {{(64-(W)){1'b0}}, v})
    localparam integer FX = (PIX_F > BREG_F) ? PIX_F : BREG_F;
    localparam integer FE_ROW = (B_F > P_F) ? B_F : P_F;
    localparam integer FP_ROW = POLE_F + FE_ROW;
    localparam integer FS_ROW = (P_F > FP_ROW) ? P_F : FP_ROW;
    localparam integer FE_COL = (R1_F > Q_F) ? R1_F : Q_F;
    localparam integer FP_COL = POLE_F + FE_COL;
    localparam integer FS_COL = (Q_F > FP_COL) ? Q_F : FP_COL;

    wire signed [63:0] pole = `RFX_SX(pole_raw, POLE_W, POLE_S);
    wire signed [63:0] bias = `RFX_SX(bias_raw, BREG_W, BREG_S);

    // ---- stage 1: input cast and bias --------------------------------------------------
    wire [PIX_W-1:0] x;
    wire [B_W-1:0]   b_next;
    wire             unused_ovf0, unused_ovf1;
    fx_cast #(0, PIX_W, PIX_F, PIX_S, PIX_Q, PIX_O) c_pix (
        .x(`RFX_SX(s_data, PIX_W, PIX_S)), .y(x), .ovf(unused_ovf0));
    wire signed [63:0] x64 = `RFX_SX(x, PIX_W, PIX_S);
    fx_cast #(FX, B_W, B_F, B_S, B_Q, B_O) c_bias (
        .x((x64 <<< (FX - PIX_F)) + (bias <<< (FX - BREG_F))), .y(b_next), .ovf(unused_ovf1));

    reg [ADDR_W-1:0] col0, col1, col2;   // column of the pixel at each stage
    reg              first_row0, first_row1, first_row2;
    reg              v1, v2, sof1, sof2, eol1, eol2;
    reg [B_W-1:0]    b1, b2;

    // column counter and first-row flag of the incoming pixel
    reg [ADDR_W-1:0] col_cnt;
    reg              in_first_row;
    wire [ADDR_W-1:0] col_in = s_sof ? {ADDR_W{1'b0}} : col_cnt;
    wire              row0_in = s_sof ? 1'b1 : in_first_row;

    // ---- stage 2: row filter (one state register) ---------------------------------------
    reg  [P_W-1:0]  p_reg;
    wire [P_W-1:0]  p_init;
    wire [P_W-1:0]  p_next;
    wire [R1_W-1:0] r1_next;
    wire [R2_W-1:0] r2_next;
    wire            unused_ovf2, unused_ovf3, unused_ovf4, unused_ovf5;
    fx_cast #(B_F, P_W, P_F, P_S, P_Q, P_O) c_pinit (
        .x(`RFX_SX(b1, B_W, B_S)), .y(p_init), .ovf(unused_ovf2));
    wire [P_W-1:0] p_cur = (col1 == {ADDR_W{1'b0}}) ? (INIT_FIRST ? p_init : {P_W{1'b0}}) : p_reg;
    wire signed [63:0] p64 = `RFX_SX(p_cur, P_W, P_S);
    wire signed [63:0] row_prod =
        pole * ((`RFX_SX(b1, B_W, B_S) <<< (FE_ROW - B_F)) - (p64 <<< (FE_ROW - P_F)));
    fx_cast #(FP_ROW, R2_W, R2_F, R2_S, R2_Q, R2_O) c_r2 (
        .x(row_prod), .y(r2_next), .ovf(unused_ovf3));
    fx_cast #(FS_ROW, P_W, P_F, P_S, P_Q, P_O) c_pnext (
        .x((p64 <<< (FS_ROW - P_F)) + (row_prod <<< (FS_ROW - FP_ROW))), .y(p_next),
        .ovf(unused_ovf4));
    wire signed [63:0] pn64 = `RFX_SX(p_next, P_W, P_S);
    fx_cast #(CONSISTENT ? P_F + 1 : P_F, R1_W, R1_F, R1_S, R1_Q, R1_O) c_r1 (
        .x(CONSISTENT ? p64 + pn64 : p64), .y(r1_next), .ovf(unused_ovf5));

    reg [R1_W-1:0] r1_2;
    reg [R2_W-1:0] r2_2;
    reg [P_W-1:0]  pn_2;

    // ---- line buffer of the column filter: read in stage 2, written back in stage 3 -----
    reg [Q_W-1:0] lb [0:MAX_WIDTH-1];
    reg [Q_W-1:0] lb_rd;

    // ---- stage 3: column filter ------------------------------------------------------------
    wire [Q_W-1:0]  q_init;
    wire [Q_W-1:0]  q_next;
    wire [S1_W-1:0] s1_next;
    wire [S2_W-1:0] s2_next;
    wire            unused_ovf6, unused_ovf7, unused_ovf8, unused_ovf9;
    fx_cast #(R1_F, Q_W, Q_F, Q_S, Q_Q, Q_O) c_qinit (
        .x(`RFX_SX(r1_2, R1_W, R1_S)), .y(q_init), .ovf(unused_ovf6));
    wire [Q_W-1:0] q_cur = first_row2 ? (INIT_FIRST ? q_init : {Q_W{1'b0}}) : lb_rd;
    wire signed [63:0] q64 = `RFX_SX(q_cur, Q_W, Q_S);
    wire signed [63:0] col_prod =
        pole * ((`RFX_SX(r1_2, R1_W, R1_S) <<< (FE_COL - R1_F)) - (q64 <<< (FE_COL - Q_F)));
    fx_cast #(FP_COL, S2_W, S2_F, S2_S, S2_Q, S2_O) c_s2 (
        .x(col_prod), .y(s2_next), .ovf(unused_ovf7));
    fx_cast #(FS_COL, Q_W, Q_F, Q_S, Q_Q, Q_O) c_qnext (
        .x((q64 <<< (FS_COL - Q_F)) + (col_prod <<< (FS_COL - FP_COL))), .y(q_next),
        .ovf(unused_ovf8));
    wire signed [63:0] qn64 = `RFX_SX(q_next, Q_W, Q_S);
    fx_cast #(CONSISTENT ? Q_F + 1 : Q_F, S1_W, S1_F, S1_S, S1_Q, S1_O) c_s1 (
        .x(CONSISTENT ? q64 + qn64 : q64), .y(s1_next), .ovf(unused_ovf9));

    reg [B_W-1:0] b3;

    always @(posedge clk) begin
        if (rst) begin
            v1 <= 1'b0; v2 <= 1'b0; m_valid <= 1'b0;
            col_cnt <= {ADDR_W{1'b0}}; in_first_row <= 1'b1;
            sof1 <= 1'b0; sof2 <= 1'b0; eol1 <= 1'b0; eol2 <= 1'b0;
            m_sof <= 1'b0; m_eol <= 1'b0;
        end else begin
            // stage 1
            v1 <= s_valid;
            if (s_valid) begin
                b1 <= b_next;
                col1 <= col_in;
                first_row1 <= row0_in;
                sof1 <= s_sof;
                eol1 <= s_eol;
                col_cnt <= s_eol ? {ADDR_W{1'b0}} : col_in + 1'b1;
                in_first_row <= s_eol ? 1'b0 : row0_in;
            end
            // stage 2
            v2 <= v1;
            if (v1) begin
                p_reg <= p_next;
                r1_2 <= r1_next;
                r2_2 <= r2_next;
                pn_2 <= p_next;
                b2 <= b1;
                col2 <= col1;
                first_row2 <= first_row1;
                sof2 <= sof1;
                eol2 <= eol1;
                lb_rd <= lb[col1];
            end
            // stage 3
            m_valid <= v2;
            if (v2) begin
                lb[col2] <= q_next;
                bias_in <= b2;
                row_state <= pn_2;
                row_r1 <= r1_2;
                row_r2 <= r2_2;
                col_state <= q_next;
                col_s1 <= s1_next;
                col_s2 <= s2_next;
                m_sof <= sof2;
                m_eol <= eol2;
            end
        end
    end
`undef RFX_SX
endmodule
