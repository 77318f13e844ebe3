// p2_top: rangefx P2, the line-buffered Riccati sweep (docs/p2_datapath.md, "Hardware"),
// one pixel per clock; AXI4-Stream video in (s0 = E1, s1 = E2, TUSER = start of frame,
// TLAST = end of line, no back-pressure) and out (TDATA = {valid, range}, TUSER on the
// frame's first word, TLAST on each lane group's last word: the interleaved order).
//
// Units and their cycles (r: a sweep slot's line-buffer read, t: a forward slot's
// sweep-buffer read; T_B = 1 + T_DIV + 2 the sweep's loop latency):
//   beat + 1  x1, x2 = cast(E, pix)          beat + 2  d, g_hat (tap), line-buffer write
//   r + 1     d_k, G_k read                   r + 2     a, dG, |D| >= T_D
//   r + 3     c (loop entry: S~_k+1, Q~_k+1)  r + 4     den (divider operand), h
//   r + 4 + T_DIV  r                          r + 3 + T_B  write-back: s, q and the taps
//   t + 1     e operand (tap e)               t + 2..4  w, lam, z (taps)
//   t + 5     valid, range                    t + 6     output register (taps, m_axis)
// Lines are taken in groups of LANES (ping-pong line and sweep buffers, bank = group mod 2);
// a group's sweep runs WIDTH columns x P_B cycles (column WIDTH-1's slot loads S~_end,
// Q~ = 0), its forward pass WIDTH x P_F; the controllers start them as the model's
// schedule does (rtl_model/p2/model.py group_starts). Flags (sticky): align_error (the two
// inputs' TVALID/TUSER/TLAST differ), line_too_long (a line over WIDTH pixels: its extra
// pixels are dropped), overrun (a group's first pixel would overwrite a line buffer its
// sweep has not read: the lanes cannot sustain the rate). Overflow counters (32 bits)
// count every cast whose overflow mode acted, per signal, as the model counts them.
`timescale 1ns / 1ps
module p2_top #(
    parameter integer WIDTH = 32,
    parameter integer HEIGHT = 8,
    parameter integer LANES = 11,
    parameter integer T_DIV = 8,        // rtl_model/runtime.py divider_latency
    parameter integer DIVIDER = 1,      // 1 reciprocal, 0 restoring
    parameter integer RECIP_L = 8,
    parameter integer RECIP_R = 20,
    parameter ROM_FILE = "recip_rom.mem",
`include "p2_params.vh"
) (
    input  wire              clk,
    input  wire              rst,
    input  wire [KA_W-1:0]   ka_raw,
    input  wire [MR_W-1:0]   m_raw,
    input  wire [C_W-1:0]    cmin_raw,
    input  wire [ST_W-1:0]   send_raw,
    input  wire [D_W+1:0]    td_raw,
    input  wire [Z_W-1:0]    rmax_raw,
    input  wire              s0_axis_tvalid,
    input  wire [PIX_W-1:0]  s0_axis_tdata,
    input  wire              s0_axis_tuser,
    input  wire              s0_axis_tlast,
    input  wire              s1_axis_tvalid,
    input  wire [PIX_W-1:0]  s1_axis_tdata,
    input  wire              s1_axis_tuser,
    input  wire              s1_axis_tlast,
    output reg               m_axis_tvalid,
    output reg  [Z_W:0]      m_axis_tdata,
    output reg               m_axis_tuser,
    output reg               m_axis_tlast,
    output reg               align_error,
    output reg               line_too_long,
    output reg               overrun,
    output reg  [31:0]       ovf_pix, ovf_d, ovf_ghat, ovf_a, ovf_c, ovf_den, ovf_r,
    output reg  [31:0]       ovf_st, ovf_h, ovf_q, ovf_w, ovf_lam, ovf_z, ovf_e
);
    localparam integer T_B = 1 + T_DIV + 2;
    localparam integer P_B = (LANES > T_B) ? LANES : T_B;
    localparam integer P_F = (LANES > 4) ? LANES : 4;
    localparam integer LW = (LANES > 1) ? $clog2(LANES) : 1;      // lane index
    localparam integer PBW = $clog2(P_B + 1);                     // sweep phase
    localparam integer PFW = $clog2(P_F + 1);                     // forward phase
    localparam integer XW = (WIDTH > 1) ? $clog2(WIDTH) : 1;      // column
    localparam integer YW = $clog2(HEIGHT + 1);                   // row
    localparam integer DEPTH = 2 * LANES * WIDTH;                 // one buffer, both banks
    localparam integer AW = $clog2(DEPTH);
    localparam integer DG_W = G_W + 1;                            // G_k+1 - G_k
    // aligned fraction bits of the sums (rtl_model/p2/model.py _fracs)
    localparam integer F_U = (E_F > G_F) ? E_F : G_F;
    localparam integer F_DEN = (C_F + ST_F > 0) ? C_F + ST_F : 0;
    localparam integer F_S = (MR_F > R_F + ST_F) ? MR_F : R_F + ST_F;
    localparam integer F_H = (Q_F > ST_F + G_F) ? Q_F : ST_F + G_F;
    localparam integer F_W = (ST_F + F_U > Q_F) ? ST_F + F_U : Q_F;
    localparam integer F_E = (F_U > A_F + Z_F) ? F_U : A_F + Z_F;
    localparam [47:0] SWEEP_LEN = WIDTH * P_B;
    localparam [47:0] FWD_LEN = WIDTH * P_F;
    // the sweep-buffer hold: a sweep starts no earlier than H after the forward start of
    // the group two before (model: (n - 2) P_f - P_b - SWEEP_READ - T_b)
    localparam signed [47:0] HOLD = (WIDTH - 2) * P_F - P_B - 3 - T_B;
    localparam integer SB_W = A_W + R_W + ST_W + Q_W + DG_W + 1;

    reg [47:0] now;
    always @(posedge clk) now <= rst ? 48'd0 : now + 48'd1;

    // ---- input stage ---------------------------------------------------------------
    wire [PIX_W-1:0] x1_n, x2_n;
    wire ovf_x1, ovf_x2;
    fx_cast_sized #(PIX_W + 1, 0, PIX_W, PIX_F, PIX_S, PIX_Q, PIX_O) c_x1 (
        .x({(PIX_S != 0) & s0_axis_tdata[PIX_W-1], s0_axis_tdata}), .y(x1_n), .ovf(ovf_x1));
    fx_cast_sized #(PIX_W + 1, 0, PIX_W, PIX_F, PIX_S, PIX_Q, PIX_O) c_x2 (
        .x({(PIX_S != 0) & s1_axis_tdata[PIX_W-1], s1_axis_tdata}), .y(x2_n), .ovf(ovf_x2));
    // beat counters: column, lane, bank, row of the beat in flight
    reg [XW:0] in_col;
    reg [LW-1:0] in_lane;
    reg in_bank;
    reg [YW-1:0] in_row;
    wire [YW-1:0] row_now = s0_axis_tuser ? {YW{1'b0}} : in_row;
    wire [LW-1:0] lane_now = s0_axis_tuser ? {LW{1'b0}} : in_lane;
    wire bank_now = s0_axis_tuser ? 1'b0 : in_bank;
    wire [XW:0] col_now = s0_axis_tuser ? {(XW+1){1'b0}} : in_col;
    wire keep = s0_axis_tvalid && (col_now < WIDTH);
    // t+1
    reg v1;
    reg [PIX_W-1:0] x1, x2;
    reg [AW-1:0] a1;
    reg last1, first1;
    reg [LW-1:0] lane1;
    reg bank1;
    reg ox1, ox2;
    always @(posedge clk) begin
        if (rst) begin
            in_col <= 0; in_lane <= 0; in_bank <= 1'b0; in_row <= 0;
            v1 <= 1'b0; align_error <= 1'b0; line_too_long <= 1'b0;
        end else begin
            if (s0_axis_tvalid != s1_axis_tvalid || (s0_axis_tvalid && (
                    s0_axis_tuser != s1_axis_tuser || s0_axis_tlast != s1_axis_tlast)))
                align_error <= 1'b1;
            if (s0_axis_tvalid && col_now >= WIDTH) line_too_long <= 1'b1;
            if (s0_axis_tvalid) begin
                if (s0_axis_tlast) begin
                    in_col <= 0;
                    in_row <= row_now + 1'b1;
                    if (lane_now == LANES - 1) begin
                        in_lane <= 0;
                        in_bank <= ~bank_now;
                    end else begin
                        in_lane <= lane_now + 1'b1;
                        in_bank <= bank_now;
                    end
                end else begin
                    in_col <= col_now + 1'b1;
                    in_row <= row_now; in_lane <= lane_now; in_bank <= bank_now;
                end
            end
            v1 <= keep;
        end
        x1 <= x1_n;
        x2 <= x2_n;
        ox1 <= ovf_x1;
        ox2 <= ovf_x2;
        a1 <= (bank_now * LANES + lane_now) * WIDTH + col_now[XW-1:0];
        // the group's last pixel: its last line (lane LANES-1 or the frame's last row)
        last1 <= (col_now == WIDTH - 1) && (lane_now == LANES - 1 || row_now == HEIGHT - 1);
        first1 <= (col_now == 0) && (lane_now == 0);
        lane1 <= lane_now;
        bank1 <= bank_now;
    end
    // t+2: d = cast(x1 - x2), g = cast(x1 + x2) (tap d, g_hat), written to the line buffer
    wire signed [PIX_W+1:0] x1s = {{2{(PIX_S != 0) & x1[PIX_W-1]}}, x1};
    wire signed [PIX_W+1:0] x2s = {{2{(PIX_S != 0) & x2[PIX_W-1]}}, x2};
    wire [D_W-1:0] d_n;
    wire [G_W-1:0] g_n;
    wire ovf_dn, ovf_gn;
    fx_cast_sized #(PIX_W + 2, PIX_F, D_W, D_F, D_S, D_Q, D_O) c_d (
        .x(x1s - x2s), .y(d_n), .ovf(ovf_dn));
    fx_cast_sized #(PIX_W + 2, PIX_F, G_W, G_F, G_S, G_Q, G_O) c_g (
        .x(x1s + x2s), .y(g_n), .ovf(ovf_gn));
    reg v2, last2, first2, od2, og2, ox1_2, ox2_2;
    reg [D_W-1:0] d2;
    reg [G_W-1:0] g2;
    reg [AW-1:0] a2w;
    reg [LW-1:0] lane2;
    reg bank2;
    always @(posedge clk) begin
        v2 <= rst ? 1'b0 : v1;
        {d2, g2, a2w, last2, first2, lane2, bank2} <= {d_n, g_n, a1, last1, first1, lane1, bank1};
        {od2, og2, ox1_2, ox2_2} <= {ovf_dn, ovf_gn, ox1, ox2};
    end
    reg [D_W+G_W-1:0] lb [0:DEPTH-1];
    always @(posedge clk) if (v2) lb[a2w] <= {d2, g2};

    // ---- the sweep controller ----------------------------------------------------------
    reg [1:0] ready;                 // per bank: a group is in the line buffer
    reg [LW:0] lines [0:1];          // per bank: the group's lines
    reg [1:0] lb_busy;               // per bank: its sweep has reads left
    reg [1:0] used;                  // per bank: a sweep has filled its sweep buffer
    reg [1:0] f_started;             // per bank: that group's forward pass has started
    reg [47:0] f_start [0:1];
    reg [1:0] f_pend;                // per bank: a swept group waits for its forward pass
    reg [47:0] f_ready [0:1];
    reg sw_run, sw_bank, sw_next;
    reg [PBW-1:0] sw_ph;
    reg [XW-1:0] sw_t;               // slot: column WIDTH-1-sw_t
    wire signed [47:0] since_f = $signed(now - f_start[sw_next]);
    wire hold_ok = !used[sw_next] || (f_started[sw_next] && since_f >= HOLD);
    wire sw_go = !sw_run && ready[sw_next] && hold_ok;
    wire sw_on = sw_go || sw_run;
    wire [PBW-1:0] ph = sw_go ? {PBW{1'b0}} : sw_ph;
    wire [XW-1:0] st_t = sw_go ? {XW{1'b0}} : sw_t;
    wire sb_bank = sw_go ? sw_next : sw_bank;
    wire [LW:0] sw_lines = lines[sb_bank];
    wire r_v = sw_on && (ph < sw_lines);
    wire [XW-1:0] r_col = WIDTH - 1 - st_t;
    wire sw_last_read = sw_on && (ph == LANES - 1) && (st_t == WIDTH - 1);
    wire sw_end = sw_on && (ph == P_B - 1) && (st_t == WIDTH - 1);

    // ---- the forward controller ---------------------------------------------------------
    reg fw_run, fw_bank, fw_next;
    reg [PFW-1:0] fw_ph;
    reg [XW-1:0] fw_k;
    wire fw_go = !fw_run && f_pend[fw_next] && (now >= f_ready[fw_next]);
    wire fw_on = fw_go || fw_run;
    wire [PFW-1:0] fph = fw_go ? {PFW{1'b0}} : fw_ph;
    wire [XW-1:0] fk = fw_go ? {XW{1'b0}} : fw_k;
    wire fb = fw_go ? fw_next : fw_bank;
    reg [LW:0] sw_lines_b [0:1];     // per bank: the lines of the group swept into it
    reg [LW:0] fw_lines_r;
    wire [LW:0] fw_lines = fw_go ? sw_lines_b[fw_next] : fw_lines_r;
    wire t_v = fw_on && (fph < fw_lines);
    wire fw_end = fw_on && (fph == P_F - 1) && (fk == WIDTH - 1);

    always @(posedge clk) begin
        if (rst) begin
            ready <= 2'b00; lb_busy <= 2'b00; used <= 2'b00; f_started <= 2'b00;
            f_pend <= 2'b00; overrun <= 1'b0;
            sw_run <= 1'b0; sw_bank <= 1'b0; sw_next <= 1'b0; sw_ph <= 0; sw_t <= 0;
            fw_run <= 1'b0; fw_bank <= 1'b0; fw_next <= 1'b0; fw_ph <= 0; fw_k <= 0;
        end else begin
            // the input side: a group's first pixel claims its bank, its last one is ready
            if (v2 && first2) begin
                if (lb_busy[bank2] || ready[bank2]) overrun <= 1'b1;
                lb_busy[bank2] <= 1'b1;
            end
            if (v2 && last2) begin
                ready[bank2] <= 1'b1;
                lines[bank2] <= lane2 + 1'b1;
            end
            if (sw_last_read) lb_busy[sb_bank] <= 1'b0;
            if (sw_go) begin
                ready[sw_next] <= 1'b0;
                used[sw_next] <= 1'b1;
                f_started[sw_next] <= 1'b0;
                f_pend[sw_next] <= 1'b1;
                f_ready[sw_next] <= now + SWEEP_LEN + T_B;
                sw_lines_b[sw_next] <= lines[sw_next];
                sw_bank <= sw_next;
                sw_next <= ~sw_next;
            end
            if (sw_on) begin
                sw_run <= !sw_end;
                sw_ph <= (ph == P_B - 1) ? {PBW{1'b0}} : ph + 1'b1;
                sw_t <= (ph == P_B - 1) ? st_t + 1'b1 : st_t;
            end
            if (fw_go) begin
                f_pend[fw_next] <= 1'b0;
                f_started[fw_next] <= 1'b1;
                f_start[fw_next] <= now;
                fw_lines_r <= sw_lines_b[fw_next];
                fw_bank <= fw_next;
                fw_next <= ~fw_next;
            end
            if (fw_on) begin
                fw_run <= !fw_end;
                fw_ph <= (fph == P_F - 1) ? {PFW{1'b0}} : fph + 1'b1;
                fw_k <= (fph == P_F - 1) ? fk + 1'b1 : fk;
            end
        end
    end

    // ---- the sweep engine ------------------------------------------------------------
    // r: the line-buffer read; every stage carries (valid, first, lane, column, bank)
    localparam integer TAGW = 2 + LW + XW + 1;
    wire [TAGW-1:0] tag_r = {r_v, (st_t == 0), ph[LW-1:0], r_col, sb_bank};
    reg [D_W+G_W-1:0] rd1;
    reg [TAGW-1:0] tag1;
    always @(posedge clk) begin
        rd1 <= lb[(sb_bank * LANES + ph[LW-1:0]) * WIDTH + r_col];
        tag1 <= rst ? {TAGW{1'b0}} : tag_r;
    end
    // r+1: D = d_k + d_k+1, dG = G_k+1 - G_k (d_k+1, G_k+1 from the lane's previous slot)
    wire v_1 = tag1[TAGW-1];
    wire [LW-1:0] lane_1 = tag1[XW+1 +: LW];
    reg [D_W-1:0] nb_d [0:LANES-1];
    reg [G_W-1:0] nb_g [0:LANES-1];
    wire [D_W-1:0] dk = rd1[D_W+G_W-1:G_W];
    wire [G_W-1:0] gk = rd1[G_W-1:0];
    wire [D_W-1:0] dk1 = nb_d[lane_1];
    wire [G_W-1:0] gk1 = nb_g[lane_1];
    wire signed [D_W+1:0] dsum = $signed({{2{(D_S != 0) & dk[D_W-1]}}, dk})
                               + $signed({{2{(D_S != 0) & dk1[D_W-1]}}, dk1});
    wire signed [DG_W-1:0] dg = $signed({(G_S != 0) & gk1[G_W-1], gk1})
                              - $signed({(G_S != 0) & gk[G_W-1], gk});
    wire [D_W+1:0] dabs = dsum[D_W+1] ? -dsum : dsum;
    wire signed [KA_W:0] ka_s = {(KA_S != 0) & ka_raw[KA_W-1], ka_raw};
    wire signed [KA_W+D_W+2:0] ka_d = ka_s * dsum;
    wire [A_W-1:0] a_n;
    wire ovf_an;
    fx_cast_sized #(KA_W + D_W + 3, KA_F + D_F, A_W, A_F, A_S, A_Q, A_O) c_a (
        .x(ka_d), .y(a_n), .ovf(ovf_an));
    reg [A_W-1:0] a2;
    reg [DG_W-1:0] dg2;
    reg thr2, oa2;
    reg [TAGW-1:0] tag2;
    always @(posedge clk) begin
        if (v_1) begin
            nb_d[lane_1] <= dk;
            nb_g[lane_1] <= gk;
        end
        a2 <= a_n;
        dg2 <= dg;
        thr2 <= (dabs >= td_raw);
        oa2 <= ovf_an;
        tag2 <= rst ? {TAGW{1'b0}} : tag1;
    end
    // r+2: c = max(cast(a^2), C_MIN)
    wire signed [A_W:0] a2s = {(A_S != 0) & a2[A_W-1], a2};
    wire signed [2*A_W+1:0] asq = a2s * a2s;
    wire [C_W-1:0] c_n;
    wire ovf_cn;
    fx_cast_sized #(2 * A_W + 2, 2 * A_F, C_W, C_F, C_S, C_Q, C_O) c_c (
        .x(asq), .y(c_n), .ovf(ovf_cn));
    reg [C_W-1:0] c3;
    reg [A_W-1:0] a3;
    reg [DG_W-1:0] dg3;
    reg thr3, oa3, oc3;
    reg [TAGW-1:0] tag3;
    always @(posedge clk) begin
        c3 <= (c_n < cmin_raw) ? cmin_raw : c_n;   // unsigned (validated by the config)
        {a3, dg3, thr3, oa3, oc3} <= {a2, dg2, thr2, oa2, ovf_cn};
        tag3 <= rst ? {TAGW{1'b0}} : tag2;
    end
    // r+3, the loop entry: S~_k+1, Q~_k+1 of the lane (bypassed from the write-back)
    wire v_3 = tag3[TAGW-1];
    wire [LW-1:0] lane_3 = tag3[XW+1 +: LW];
    reg [ST_W-1:0] s_state [0:LANES-1];
    reg [Q_W-1:0] q_state [0:LANES-1];
    reg [ST_W-1:0] s_wb;
    reg [Q_W-1:0] q_wb;
    reg [TAGW-1:0] tag_wb;
    wire wb_v = tag_wb[TAGW-1];
    wire [LW-1:0] wb_lane = tag_wb[XW+1 +: LW];
    wire byp = wb_v && (wb_lane == lane_3);
    wire [ST_W-1:0] s_op = byp ? s_wb : s_state[lane_3];
    wire [Q_W-1:0] q_op = byp ? q_wb : q_state[lane_3];
    wire signed [ST_W:0] s_op_s = {1'b0, s_op};
    wire signed [Q_W:0] q_op_s = {(Q_S != 0) & q_op[Q_W-1], q_op};
    wire signed [C_W:0] c3s = {1'b0, c3};
    // den = cast(1 + c S~)
    localparam integer DN_W = C_W + ST_W + 4 + F_DEN + (F_DEN - C_F - ST_F);
    wire signed [DN_W-1:0] cs = c3s * s_op_s;
    wire signed [DN_W-1:0] den_x = ($signed({{(DN_W-1){1'b0}}, 1'b1}) <<< F_DEN)
                                 + (cs <<< (F_DEN - C_F - ST_F));
    wire [DEN_W-1:0] den_n;
    wire ovf_denn;
    fx_cast_sized #(DN_W, F_DEN, DEN_W, DEN_F, DEN_S, DEN_Q, DEN_O) c_den (
        .x(den_x), .y(den_n), .ovf(ovf_denn));
    // h = cast(Q~ - S~ dG)
    localparam integer HN_W = ((Q_W + 1 + F_H - Q_F > ST_W + 1 + DG_W + F_H - ST_F - G_F)
                               ? Q_W + 1 + F_H - Q_F : ST_W + 1 + DG_W + F_H - ST_F - G_F) + 2;
    wire signed [DG_W-1:0] dg3s = dg3;
    wire signed [HN_W-1:0] sdg = s_op_s * dg3s;
    wire signed [HN_W-1:0] qx = q_op_s;
    wire signed [HN_W-1:0] h_x = (qx <<< (F_H - Q_F)) - (sdg <<< (F_H - ST_F - G_F));
    wire [H_W-1:0] h_n;
    wire ovf_hn;
    fx_cast_sized #(HN_W, F_H, H_W, H_F, H_S, H_Q, H_O) c_h (.x(h_x), .y(h_n), .ovf(ovf_hn));
    reg [DEN_W-1:0] den4;
    reg [H_W-1:0] h4;
    reg oden4, oh4;
    reg [TAGW-1:0] tag4;
    always @(posedge clk) begin
        {den4, h4, oden4, oh4} <= {den_n, h_n, ovf_denn, ovf_hn};
        tag4 <= rst ? {TAGW{1'b0}} : tag3;
    end
    // the divider: r = divide(1, den) at r + 4 + T_DIV
    wire [R_W-1:0] r_q;
    wire ovf_rq;
    generate
        if (DIVIDER != 0) begin : g_recip
            fx_div_reciprocal #(2, 0, DEN_W + 1, DEN_F, R_W, R_F, R_S, R_Q, R_O, RECIP_L,
                                RECIP_R, ROM_FILE, 0) u_div (
                .clk(clk), .n(2'sb01), .d({1'b0, den4}), .y(r_q), .ovf(ovf_rq));
        end else begin : g_rest
            fx_div_restoring #(2, 0, DEN_W + 1, DEN_F, R_W, R_F, R_S, R_Q, R_O, 0) u_div (
                .clk(clk), .n(2'sb01), .d({1'b0, den4}), .y(r_q), .ovf(ovf_rq));
        end
    endgenerate
    // the values that wait beside the divider (r+3 -> r+4+T_DIV)
    localparam integer SIDE_W = A_W + C_W + DG_W + 1 + 2 + ST_W + Q_W;
    wire [SIDE_W-1:0] side_in = {a3, c3, dg3, thr3, oa3, oc3, s_op, q_op};
    wire [SIDE_W-1:0] side_out;
    wire [DEN_W+H_W+2-1:0] side2_out;
    wire [TAGW-1:0] tag_d;
    fx_delay #(SIDE_W, 1 + T_DIV) u_side (.clk(clk), .d(side_in), .q(side_out));
    fx_delay #(DEN_W + H_W + 2, T_DIV) u_side2 (.clk(clk), .d({den4, h4, oden4, oh4}),
                                                .q(side2_out));
    fx_delay #(TAGW, T_DIV) u_tagd (.clk(clk), .d(tag4), .q(tag_d));
    // r + 4 + T_DIV: the products r S~_k+1, r h
    wire [ST_W-1:0] s_old = side_out[Q_W +: ST_W];
    wire [H_W-1:0] h_d = side2_out[2 +: H_W];
    wire signed [R_W:0] r_s = {(R_S != 0) & r_q[R_W-1], r_q};
    wire signed [R_W+ST_W+1:0] rs_n = r_s * $signed({1'b0, s_old});
    wire signed [R_W+H_W+1:0] rh_n = r_s * $signed({(H_S != 0) & h_d[H_W-1], h_d});
    reg signed [R_W+ST_W+1:0] rs5;
    reg signed [R_W+H_W+1:0] rh5;
    reg [R_W-1:0] r5;
    reg or5;
    reg [SIDE_W-1:0] side5;
    reg [DEN_W+H_W+2-1:0] side25;
    reg [TAGW-1:0] tag5;
    always @(posedge clk) begin
        {rs5, rh5, r5, or5, side5, side25} <= {rs_n, rh_n, r_q, ovf_rq, side_out, side2_out};
        tag5 <= rst ? {TAGW{1'b0}} : tag_d;
    end
    // r + 5 + T_DIV: S~_k = cast(M + r S~_k+1), Q~_k = cast(r h) -> the write-back
    localparam integer SN_W = ((MR_W + 1 + F_S - MR_F > R_W + ST_W + 2 + F_S - R_F - ST_F)
                               ? MR_W + 1 + F_S - MR_F : R_W + ST_W + 2 + F_S - R_F - ST_F) + 2;
    wire signed [SN_W-1:0] m_x = $signed({(MR_S != 0) & m_raw[MR_W-1], m_raw});
    wire signed [SN_W-1:0] rs_x = rs5;
    wire signed [SN_W-1:0] s_x = (m_x <<< (F_S - MR_F)) + (rs_x <<< (F_S - R_F - ST_F));
    wire [ST_W-1:0] s_n;
    wire [Q_W-1:0] q_n;
    wire ovf_sn, ovf_qn;
    fx_cast_sized #(SN_W, F_S, ST_W, ST_F, ST_S, ST_Q, ST_O) c_s (
        .x(s_x), .y(s_n), .ovf(ovf_sn));
    fx_cast_sized #(R_W + H_W + 2, R_F + H_F, Q_W, Q_F, Q_S, Q_Q, Q_O) c_q (
        .x(rh5), .y(q_n), .ovf(ovf_qn));
    wire first5 = tag5[TAGW-2];
    wire v5 = tag5[TAGW-1];
    wire count5 = v5 && !first5;
    // write-back registers: the sweep's taps a, c, den, r, s, h, q (column WIDTH-1: the
    // start values, the others 0)
    reg [A_W-1:0] wb_a;
    reg [C_W-1:0] wb_c;
    reg [DEN_W-1:0] wb_den;
    reg [R_W-1:0] wb_r;
    reg [H_W-1:0] wb_h;
    reg [ST_W-1:0] wb_sold;
    reg [Q_W-1:0] wb_qold;
    reg [DG_W-1:0] wb_dg;
    reg wb_thr;
    always @(posedge clk) begin
        s_wb <= first5 ? send_raw : s_n;
        q_wb <= first5 ? {Q_W{1'b0}} : q_n;
        wb_a <= first5 ? {A_W{1'b0}} : side5[SIDE_W-1 -: A_W];
        wb_c <= first5 ? {C_W{1'b0}} : side5[SIDE_W-A_W-1 -: C_W];
        wb_den <= first5 ? {DEN_W{1'b0}} : side25[DEN_W+H_W+1 -: DEN_W];
        wb_r <= first5 ? {R_W{1'b0}} : r5;
        wb_h <= first5 ? {H_W{1'b0}} : side25[H_W+1 : 2];
        wb_sold <= side5[Q_W +: ST_W];
        wb_qold <= side5[Q_W-1:0];
        wb_dg <= side5[SIDE_W-A_W-C_W-1 -: DG_W];
        wb_thr <= side5[ST_W+Q_W+2];
        tag_wb <= rst ? {TAGW{1'b0}} : tag5;
        if (wb_v) begin
            s_state[wb_lane] <= s_wb;
            q_state[wb_lane] <= q_wb;
        end
    end
    // overflow counts of the sweep (per signal, a slot's casts once; not the first slot's)
    always @(posedge clk) begin
        if (rst) begin
            ovf_pix <= 0; ovf_d <= 0; ovf_ghat <= 0; ovf_a <= 0; ovf_c <= 0; ovf_den <= 0;
            ovf_r <= 0; ovf_st <= 0; ovf_h <= 0; ovf_q <= 0;
        end else begin
            if (v2) begin
                ovf_pix <= ovf_pix + ox1_2 + ox2_2;
                ovf_d <= ovf_d + od2;
                ovf_ghat <= ovf_ghat + og2;
            end
            if (count5) begin
                ovf_a <= ovf_a + side5[ST_W+Q_W+1];
                ovf_c <= ovf_c + side5[ST_W+Q_W];
                ovf_den <= ovf_den + side25[1];
                ovf_h <= ovf_h + side25[0];
                ovf_r <= ovf_r + or5;
                ovf_st <= ovf_st + ovf_sn;
                ovf_q <= ovf_q + ovf_qn;
            end
        end
    end
    // the sweep buffer: entry (bank, lane, k) = a, r, S~_k+1, Q~_k+1, dG, |D| >= T_D of
    // step k, written at the write-back (column WIDTH-1: no entry)
    reg [SB_W-1:0] sb [0:DEPTH-1];
    wire [XW-1:0] wb_col = tag_wb[1 +: XW];
    wire wb_bank = tag_wb[0];
    always @(posedge clk)
        if (wb_v && !tag_wb[TAGW-2])
            sb[(wb_bank * LANES + wb_lane) * WIDTH + wb_col]
                <= {wb_a, wb_r, wb_sold, wb_qold, wb_dg, wb_thr};

    // ---- the forward engine -----------------------------------------------------------
    // t: the sweep-buffer read (column WIDTH-1: none, zeros); the e operand of the lane
    localparam integer FTAGW = 3 + LW + XW + 1;
    reg [SB_W-1:0] fr1_ram;          // the block RAM's registered read
    reg [FTAGW-1:0] ftag1;
    wire [SB_W-1:0] fr1 = ftag1[FTAGW-2] ? {SB_W{1'b0}} : fr1_ram;
    reg [E_W-1:0] e_state [0:LANES-1];
    reg [E_W-1:0] e_op;
    wire f_zero = (fk == WIDTH - 1);
    wire [FTAGW-1:0] ftag_t = {t_v, f_zero, fph == fw_lines - 1, fph[LW-1:0], fk, fb};
    // e_k+1 of the lane's previous slot, formed in this cycle when P_F = 4 (bypass)
    wire [E_W-1:0] e_new;
    reg [FTAGW-1:0] ftag4;
    wire e_byp = ftag4[FTAGW-1] && (ftag4[XW+1 +: LW] == fph[LW-1:0]);
    always @(posedge clk) begin
        fr1_ram <= sb[(fb * LANES + fph[LW-1:0]) * WIDTH + fk];
        ftag1 <= rst ? {FTAGW{1'b0}} : ftag_t;
        e_op <= (fk == 0) ? {E_W{1'b0}} : (e_byp ? e_new : e_state[fph[LW-1:0]]);
    end
    // the taps' valid strobes (one register each, one sample per cycle)
    wire tap_e_v = ftag1[FTAGW-1];
    wire tap_w_v = ftag2[FTAGW-1];
    wire tap_lam_v = ftag3[FTAGW-1];
    wire tap_z_v = ftag4[FTAGW-1];
    // t+1: u = e_k - dG; w = cast(S~_k+1 u + Q~_k+1)
    wire [A_W-1:0] f_a = fr1[SB_W-1 -: A_W];
    wire [R_W-1:0] f_r = fr1[SB_W-A_W-1 -: R_W];
    wire [ST_W-1:0] f_s = fr1[SB_W-A_W-R_W-1 -: ST_W];
    wire [Q_W-1:0] f_q = fr1[DG_W+1 +: Q_W];
    wire signed [DG_W-1:0] f_dg = fr1[1 +: DG_W];
    wire f_thr = fr1[0];
    localparam integer U_W = ((E_W + 1 + F_U - E_F > DG_W + F_U - G_F)
                              ? E_W + 1 + F_U - E_F : DG_W + F_U - G_F) + 1;
    wire signed [U_W-1:0] e_x = $signed({(E_S != 0) & e_op[E_W-1], e_op});
    wire signed [U_W-1:0] dg_x = f_dg;
    wire signed [U_W-1:0] u = (e_x <<< (F_U - E_F)) - (dg_x <<< (F_U - G_F));
    localparam integer WN_W = ((ST_W + 1 + U_W + F_W - ST_F - F_U > Q_W + 1 + F_W - Q_F)
                               ? ST_W + 1 + U_W + F_W - ST_F - F_U : Q_W + 1 + F_W - Q_F) + 2;
    wire signed [WN_W-1:0] su = $signed({1'b0, f_s}) * u;
    wire signed [WN_W-1:0] fq_x = $signed({(Q_S != 0) & f_q[Q_W-1], f_q});
    wire signed [WN_W-1:0] w_x = (su <<< (F_W - ST_F - F_U)) + (fq_x <<< (F_W - Q_F));
    wire [W_W-1:0] w_n;
    wire ovf_wn;
    fx_cast_sized #(WN_W, F_W, W_W, W_F, W_S, W_Q, W_O) c_w (.x(w_x), .y(w_n), .ovf(ovf_wn));
    reg [W_W-1:0] w2;
    reg [A_W-1:0] fa2, fa3, fa4;
    reg [R_W-1:0] fr2;
    reg [U_W-1:0] u2, u3, u4;
    reg thr_2, thr_3, thr_4, ow2;
    reg [FTAGW-1:0] ftag2, ftag3;
    always @(posedge clk) begin
        {w2, fa2, fr2, u2, thr_2, ow2} <= {w_n, f_a, f_r, u, f_thr, ovf_wn};
        ftag2 <= rst ? {FTAGW{1'b0}} : ftag1;
    end
    // t+2: lam = cast(r w)
    wire signed [R_W+W_W+1:0] rw = $signed({(R_S != 0) & fr2[R_W-1], fr2})
                                 * $signed({(W_S != 0) & w2[W_W-1], w2});
    wire [LAM_W-1:0] lam_n;
    wire ovf_lamn;
    fx_cast_sized #(R_W + W_W + 2, R_F + W_F, LAM_W, LAM_F, LAM_S, LAM_Q, LAM_O) c_lam (
        .x(rw), .y(lam_n), .ovf(ovf_lamn));
    reg [LAM_W-1:0] lam3;
    reg olam3, ow3;
    always @(posedge clk) begin
        {lam3, fa3, u3, thr_3, olam3, ow3} <= {lam_n, fa2, u2, thr_2, ovf_lamn, ow2};
        ftag3 <= rst ? {FTAGW{1'b0}} : ftag2;
    end
    // t+3: z = cast(-(a lam))
    wire signed [A_W:0] fa3s = {(A_S != 0) & fa3[A_W-1], fa3};
    wire signed [A_W+LAM_W+2:0] alam = fa3s * $signed({(LAM_S != 0) & lam3[LAM_W-1], lam3});
    wire signed [A_W+LAM_W+2:0] nalam = -alam;
    wire [Z_W-1:0] z_n;
    wire ovf_zn;
    fx_cast_sized #(A_W + LAM_W + 3, A_F + LAM_F, Z_W, Z_F, Z_S, Z_Q, Z_O) c_z (
        .x(nalam), .y(z_n), .ovf(ovf_zn));
    reg [Z_W-1:0] z4;
    reg oz4, olam4, ow4;
    always @(posedge clk) begin
        {z4, fa4, u4, thr_4, oz4, olam4, ow4} <= {z_n, fa3, u3, thr_3, ovf_zn, olam3, ow3};
        ftag4 <= rst ? {FTAGW{1'b0}} : ftag3;
    end
    // t+4: e_k+1 = cast(u + a z) into the lane's e state; valid, range
    localparam integer EN_W = ((U_W + F_E - F_U > A_W + Z_W + 2 + F_E - A_F - Z_F)
                               ? U_W + F_E - F_U : A_W + Z_W + 2 + F_E - A_F - Z_F) + 2;
    wire signed [Z_W:0] z4s = {(Z_S != 0) & z4[Z_W-1], z4};
    wire signed [EN_W-1:0] az = $signed({(A_S != 0) & fa4[A_W-1], fa4}) * z4s;
    wire signed [EN_W-1:0] u4x = $signed(u4);
    wire signed [EN_W-1:0] e_x2 = (u4x <<< (F_E - F_U)) + (az <<< (F_E - A_F - Z_F));
    wire ovf_en;
    fx_cast_sized #(EN_W, F_E, E_W, E_F, E_S, E_Q, E_O) c_e (.x(e_x2), .y(e_new), .ovf(ovf_en));
    wire fv4 = ftag4[FTAGW-1];
    wire fz4 = ftag4[FTAGW-2];
    wire signed [Z_W:0] rmax_s = {(Z_S != 0) & rmax_raw[Z_W-1], rmax_raw};
    wire ok4 = thr_4 && (z4s > 0) && (z4s <= rmax_s);
    reg valid5;
    reg [Z_W-1:0] range5;
    reg [FTAGW-1:0] ftag5;
    always @(posedge clk) begin
        if (fv4) e_state[ftag4[XW+1 +: LW]] <= e_new;
        valid5 <= ok4;
        range5 <= ok4 ? z4 : rmax_raw;
        ftag5 <= rst ? {FTAGW{1'b0}} : ftag4;
        if (rst) begin
            ovf_w <= 0; ovf_lam <= 0; ovf_z <= 0; ovf_e <= 0;
        end else if (fv4 && !fz4) begin
            ovf_w <= ovf_w + ow4;
            ovf_lam <= ovf_lam + olam4;
            ovf_z <= ovf_z + oz4;
            ovf_e <= ovf_e + ovf_en;
        end
    end
    // t+6: the output register (taps valid, range; m_axis): TUSER on the frame's first
    // word, TLAST on the group's last (its last lane, column WIDTH-1)
    reg out_first;
    always @(posedge clk) begin
        m_axis_tvalid <= rst ? 1'b0 : ftag5[FTAGW-1];
        m_axis_tdata <= {valid5, range5};
        m_axis_tuser <= ftag5[FTAGW-1] && out_first;
        m_axis_tlast <= ftag5[FTAGW-1] && ftag5[FTAGW-3] && (ftag5[1 +: XW] == WIDTH - 1);
        if (rst) out_first <= 1'b1;
        else if (ftag5[FTAGW-1]) out_first <= 1'b0;
    end
endmodule
