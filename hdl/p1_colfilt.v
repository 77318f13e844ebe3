// p1_colfilt: one column filter of the rangefx P1 front end (docs/p1_datapath.md step 3,
// and step 4 of the consistent variant, which runs it on r2), one pixel per clock.
//
// The state of every column lives in a line buffer memory (MAX_WIDTH words of ST_W bits):
//   cycle c-1 : the line buffer read is issued at `rd_col` (`rd_en`: the column of the
//               pixel that arrives at c; a block RAM's synchronous read)
//   cycle c   : `in_valid` with the input r (R_*), its column and first-row flag; the
//               RAM's data out registered (the DP16KD's clock-to-out ends at a register)
//   cycle c+1 : q = LB[col] (or the first-row init), prod = C (r - q) exact, registered
//   cycle c+2 : q_next = cast(q + prod, ST), s2 = cast(prod, S2), s1 = cast(q, S1)
//               (paper) or cast((q + q_next) / 2, S1) (centred); LB[col] <= q_next
//   cycle c+3 : registered outputs and their overflow flags (`out_valid`)
// Latency 3; a column's read is issued again at least 4 cycles later (line period > 3,
// rtl_model/p1/model.py LINE_BUFFER_READ_AHEAD; the model rejects shorter lines), after
// its write at c+2, so the write is always seen (read after write).
// A column >= MAX_WIDTH (a line too long, flagged by the front end) never reaches the memory.
`timescale 1ns / 1ps
module p1_colfilt #(
    parameter integer MAX_WIDTH = 1024,
    parameter integer ADDR_W = 11,
    parameter integer CENTRED = 0,    // s1 = cast((q + q_next) / 2) instead of cast(q)
    parameter integer INIT_FIRST = 1,
    parameter integer POLE_K = -1,    // -1: C from pole_raw; k >= 0: C = 2^-k, a shift
    parameter integer POLE_W = 17, parameter integer POLE_F = 16, parameter integer POLE_S = 0,
    parameter integer R_W = 20,  parameter integer R_F = 11, parameter integer R_S = 0,
    parameter integer ST_W = 22, parameter integer ST_F = 13, parameter integer ST_S = 0,
    parameter integer ST_Q = 2,  parameter integer ST_O = 1,
    parameter integer S1_W = 20, parameter integer S1_F = 11, parameter integer S1_S = 0,
    parameter integer S1_Q = 2,  parameter integer S1_O = 1,
    parameter integer S2_W = 21, parameter integer S2_F = 11, parameter integer S2_S = 1,
    parameter integer S2_Q = 2,  parameter integer S2_O = 1
) (
    input  wire              clk,
    input  wire              rst,
    input  wire [POLE_W-1:0] pole_raw,
    input  wire              rd_en,     // the next cycle's pixel: its column
    input  wire [ADDR_W-1:0] rd_col,
    input  wire              in_valid,
    input  wire [ADDR_W-1:0] col,
    input  wire              first_row,
    input  wire [R_W-1:0]    r,
    output reg  [ST_W-1:0]   q_next,
    output reg  [S1_W-1:0]   s1,
    output reg  [S2_W-1:0]   s2,
    output reg  [1:0]        ovf_st,    // state casts that overflowed: init + update
    output reg               ovf_s1,
    output reg               ovf_s2
);
    localparam integer FE = (R_F > ST_F) ? R_F : ST_F;        // r - q aligned here
    localparam integer FP = POLE_F + FE;                      // prod
    localparam integer FS = (ST_F > FP) ? ST_F : FP;          // q + prod
    localparam integer ER = R_W + 1 + FE - R_F;               // widths, signed
    localparam integer EQ = ST_W + 1 + FE - ST_F;
    localparam integer DW = ((ER > EQ) ? ER : EQ) + 1;
    localparam integer PW = POLE_W + 1 + DW;
    localparam integer SQ = ST_W + 1 + FS - ST_F;
    localparam integer SP = PW + FS - FP;
    localparam integer SW = ((SQ > SP) ? SQ : SP) + 1;

    wire signed [POLE_W:0] pole = {(POLE_S != 0) & pole_raw[POLE_W-1], pole_raw};

    // ---- cycles c-1, c: line buffer read, its data out registered -----------------------
    reg [ST_W-1:0] lb [0:MAX_WIDTH-1];
    reg [ST_W-1:0] lb_q, lb_rd;
    reg [R_W-1:0]  r1_d;
    reg [ADDR_W-1:0] col1, col2;
    reg            v1, v2, first1;
    always @(posedge clk) begin
        if (rd_en && rd_col < MAX_WIDTH) lb_q <= lb[rd_col];
        lb_rd <= lb_q;
        r1_d <= r;
        col1 <= col;
        first1 <= first_row;
        v1 <= rst ? 1'b0 : in_valid;
    end

    // ---- cycle c+1: state (or its first-row init) and the exact product ----------------
    wire signed [R_W:0]  r_s = {(R_S != 0) & r1_d[R_W-1], r1_d};
    wire [ST_W-1:0] q_init;
    wire            ovf_init;
    fx_cast_sized #(R_W + 1, R_F, ST_W, ST_F, ST_S, ST_Q, ST_O) c_init (
        .x(r_s), .y(q_init), .ovf(ovf_init));
    wire [ST_W-1:0] q_cur = first1 ? (INIT_FIRST ? q_init : {ST_W{1'b0}}) : lb_rd;
    wire signed [ST_W:0] q_s = {(ST_S != 0) & q_cur[ST_W-1], q_cur};
    wire signed [DW-1:0] r_al = r_s;
    wire signed [DW-1:0] q_al = q_s;
    wire signed [DW-1:0] diff = (r_al <<< (FE - R_F)) - (q_al <<< (FE - ST_F));
    wire signed [PW-1:0] prod = (POLE_K < 0) ? pole * diff : diff <<< (POLE_F - POLE_K);
    reg signed [PW-1:0]  prod2;
    reg  [ST_W-1:0]      q2;
    reg                  ovf_init2;
    always @(posedge clk) begin
        prod2 <= prod;
        q2 <= q_cur;
        ovf_init2 <= v1 && first1 && (INIT_FIRST != 0) && ovf_init;
        col2 <= col1;
        v2 <= rst ? 1'b0 : v1;
    end

    // ---- cycle c+2: casts, write back -----------------------------------------------------
    wire signed [ST_W:0] q2_s = {(ST_S != 0) & q2[ST_W-1], q2};
    wire signed [SW-1:0] q2_w = q2_s;
    wire signed [SW-1:0] p2_w = prod2;
    wire signed [SW-1:0] pre = (q2_w <<< (FS - ST_F)) + (p2_w <<< (FS - FP));
    wire [ST_W-1:0] qn;
    wire [S1_W-1:0] s1n;
    wire [S2_W-1:0] s2n;
    wire            ovf_qn, ovf_s1n, ovf_s2n;
    fx_cast_sized #(SW, FS, ST_W, ST_F, ST_S, ST_Q, ST_O) c_next (
        .x(pre), .y(qn), .ovf(ovf_qn));
    fx_cast_sized #(PW, FP, S2_W, S2_F, S2_S, S2_Q, S2_O) c_s2 (
        .x(prod2), .y(s2n), .ovf(ovf_s2n));
    wire signed [ST_W:0]   qn_s = {(ST_S != 0) & qn[ST_W-1], qn};
    wire signed [ST_W+1:0] qsum = q2_s + qn_s;
    generate
        if (CENTRED != 0) begin : g_centred
            fx_cast_sized #(ST_W + 2, ST_F + 1, S1_W, S1_F, S1_S, S1_Q, S1_O) c_s1 (
                .x(qsum), .y(s1n), .ovf(ovf_s1n));
        end else begin : g_paper
            fx_cast_sized #(ST_W + 1, ST_F, S1_W, S1_F, S1_S, S1_Q, S1_O) c_s1 (
                .x(q2_s), .y(s1n), .ovf(ovf_s1n));
        end
    endgenerate
    always @(posedge clk) begin
        if (v2 && col2 < MAX_WIDTH) lb[col2] <= qn;
        q_next <= qn;
        s1 <= s1n;
        s2 <= s2n;
        ovf_st <= v2 ? {ovf_init2, ovf_qn} : 2'b00;
        ovf_s1 <= v2 & ovf_s1n;
        ovf_s2 <= v2 & ovf_s2n;
    end
endmodule
