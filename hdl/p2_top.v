// p2_top: rangefx P2, the line-buffered Riccati sweep (docs/p2_datapath.md, "Hardware"),
// one pixel per clock; AXI4-Stream video in (s0 = E1, s1 = E2, TUSER = start of frame,
// TLAST = end of line, no back-pressure) and out (TDATA = {valid, range}, TUSER on each
// frame's first word, TLAST on each lane group's last word: the interleaved order).
//
// Units and their cycles (r: a sweep slot's line-buffer read, E = r + SWEEP_READ its loop
// entry, t: a forward slot's sweep-buffer read, F = t + FWD_READ; every stage holds one
// multiply (fx_mul_pipe with IREG = 1, MUL_LAT = 4 stages: the operands in the
// MULT18X18D's input registers first), one carry chain or one cast; the line and sweep
// buffers read in LB_READ = 5 cycles, p2_ram below):
//   beat + 1  x1, x2 = cast(E, pix)          beat + 2  d, g_hat (tap), line-buffer write
//   r + 5     d_k, G_k (p2_ram's output)      r + 6     D = d_k + d_k+1, dG
//   r + 10    KA D                            r + 11    a = cast(KA D)
//   r + 15    a^2                             r + 16    cast(a^2)
//   E = r+17  c = max(cast(a^2), C_MIN)       E + 1     S~_k+1, Q~_k+1 (lane state read)
//   E + 2     c, S~, dG in the DSPs' input registers
//   E + 5     c S~, S~ dG                     E + 6     1 + c S~, Q~ - S~ dG
//   E + 7     den (divider operand), h        E + 7 + T_DIV  r (the divider's cast)
//   E + 8 + T_DIV  r registered               E + 12 + T_DIV  r S~, r h
//   E + 13 + T_DIV  M + r S~                E + 14 + T_DIV  cast S~_k, Q~_k (registered)
//   E + T_B   write-back (taps a c den r s h q; S~_k, Q~_k into the lane's state),
//             T_B = 7 + T_DIV + 8; sweep-buffer entry D, r, S~_k+1, Q~_k+1, dG
//   F         sweep-buffer entry, e operand (tap e)   F + 1  u = e - dG, |D|
//   F + 2     |D| >= T_D    F + 4  KA D    F + 5  a = cast(KA D)    F + 6  -a
//   F + 5     S~ u      F + 6   + Q~      F + 7   w (tap)    F + 11  r w
//   F + 12    its rounded value           F + 13  lam (tap)  F + 17  (-a) lam
//   F + 18    its rounded value           F + 19  z (tap)    F + 23  a z
//   F + 24    u + a z   F + 25  its cast, registered into the lane's e state (T_F = 27:
//   the lane's next e operand is read at its next t + 4)
//   F + 20    valid, range (threshold)    F + 21  output register (taps, m_axis)
// Lines are taken in groups of LANES (bank = the group's parity over the whole stream of
// frames: a frame's last group ends its bank, SOF restarts only the column, lane and row
// counts; docs/p2_datapath.md "A stream of frames"); a group's sweep runs WIDTH
// columns x P_B cycles (column WIDTH-1's slot loads S~_end, Q~ = 0), its forward pass
// WIDTH x P_F; the controllers start them as the model's schedule does
// (rtl_model/p2/model.py group_starts), each slot decided the cycle before (its registers
// hold its phase, column, bank and buffer address). The ping-pong line buffer holds entry
// (lane, bank, column k) at (lane 2 + bank) WIDTH + k; the one sweep buffer (LANES WIDTH
// entries) holds it at lane WIDTH + k (bank 0) or lane WIDTH + WIDTH-1-k (bank 1), so that
// slot i of a group's sweep writes the word slot i of the previous group's forward pass
// reads, a cycle or more after that read (the sweep's start held HOLD after that forward
// start: model.py sweep_address, sweep_hold). Flags (sticky): align_error (the two
// inputs' TVALID/TUSER/TLAST differ), line_too_long (a line over WIDTH pixels: its extra
// pixels are dropped), overrun (a group's first pixel would overwrite a line buffer its
// sweep has not read: the lanes cannot sustain the rate). Overflow counters (32 bits)
// count every cast whose overflow mode acted, per signal, as the model counts them.
`timescale 1ns / 1ps
module p2_top #(
    parameter integer WIDTH = 32,
    parameter integer HEIGHT = 8,
    parameter integer LANES = 11,
    parameter integer T_DIV = 19,       // rtl_model/p2/config.py divider_latency_p2
                                        // (reciprocal: fx_div_reciprocal PIPE 2, UNIT 1,
                                        // NORM 1)
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
    // declared latencies (rtl_model/p2/config.py): every unit one multiply (fx_mul_pipe,
    // MUL_LAT stages), one carry chain or one cast per cycle; block RAMs read in LB_READ
    // every product: fx_mul_pipe with IREG = 1, its operands in the MULT18X18D's input
    // registers, then the partial products, their pair sums, the final sum
    localparam integer MUL_LAT = 4;
    localparam integer LB_READ = 5;                  // p2_ram: address, read, out, ORed x2
    localparam integer FWD_READ = LB_READ;           // the sweep buffer likewise
    // the loop entry E = r + SWEEP_READ: read, D, KA D, cast a, a^2, cast, max(., C_MIN)
    localparam integer SWEEP_READ = LB_READ + 1 + MUL_LAT + 1 + MUL_LAT + 1 + 1;
    // the backward loop: operand register, c S~, + 1, cast (den at E + E_DEN), the
    // divider, r registered, r S~, + M, cast, registered into the lane's state; its
    // products with their operands in the MULT18X18D's input registers (MUL_LAT)
    localparam integer E_DEN = 1 + MUL_LAT + 1 + 1;
    localparam integer T_B = E_DEN + T_DIV + 1 + MUL_LAT + 1 + 1 + 1;
    // the forward loop, its units' cycles after F (the sweep-buffer entry and the e
    // operand): u, S~ u, + Q~, cast w (FO_W); r w, cast lam (FO_LAM: its rounded value,
    // then its overflow mode); (-a) lam, cast z (FO_Z: likewise); a z, + u, cast e,
    // registered (FO_E) into the lane's state; the e operand register read at t + 4
    localparam integer FO_W = 1 + MUL_LAT + 1 + 1;
    localparam integer FO_LAM = FO_W + MUL_LAT + 2;
    localparam integer FO_Z = FO_LAM + MUL_LAT + 2;
    localparam integer FO_E = FO_Z + MUL_LAT + 1 + 1;
    localparam integer T_F = FO_E + 2;
    localparam integer P_B = (LANES > T_B) ? LANES : T_B;
    localparam integer P_F = (LANES > T_F) ? LANES : T_F;
    localparam integer LW = (LANES > 1) ? $clog2(LANES) : 1;      // lane index
    localparam integer PBW = $clog2(P_B + 1);                     // sweep phase
    localparam integer PFW = $clog2(P_F + 1);                     // forward phase
    localparam integer XW = (WIDTH > 1) ? $clog2(WIDTH) : 1;      // column
    localparam integer YW = $clog2(HEIGHT + 1);                   // row
    localparam integer DEPTH = 2 * LANES * WIDTH;                 // line buffer, both banks
    localparam integer AW = $clog2(DEPTH);
    localparam integer SB_DEPTH = LANES * WIDTH;                  // sweep buffer, one bank
    localparam integer SAW = $clog2(SB_DEPTH);
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
    // the sweep-buffer hold: a sweep starts no earlier than HOLD after the forward start
    // of the previous group (model.py sweep_hold: its slot i, 1 <= i <= WIDTH-1, writes at
    // its write-back a cycle after that forward pass's slot i reads the same word:
    // max(P_f - P_b, (n - 1)(P_f - P_b)) - SWEEP_READ - T_b + 1). That forward start is
    // max(F_READY of the previous sweep, the forward end of the group before it); a
    // sweep waits for both + HOLD
    localparam signed [47:0] HOLD_DP = (P_F > P_B) ? (WIDTH - 1) * (P_F - P_B) : P_F - P_B;
    localparam signed [47:0] HOLD = HOLD_DP - SWEEP_READ - T_B + 1;
    localparam signed [47:0] HOLD_A = SWEEP_LEN + T_B + HOLD;     // after a sweep's start
    localparam signed [47:0] HOLD_B = FWD_LEN + HOLD;             // after a forward start
    localparam integer DS_W = D_W + 1;                            // D = d_k + d_k+1
    localparam integer SB_W = DS_W + R_W + ST_W + Q_W + DG_W;

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
    // the bank parity continues across frames (a frame's last group, short or not, ends
    // its bank): the controllers' sw_next / fw_next and the sweep buffer's column order
    // follow it, so a stream of frames needs no reset between them
    wire bank_now = in_bank;
    wire [XW:0] col_now = s0_axis_tuser ? {(XW+1){1'b0}} : in_col;
    wire keep = s0_axis_tvalid && (col_now < WIDTH);
    // t+1
    reg v1;
    reg [PIX_W-1:0] x1, x2;
    reg [AW-1:0] a1;
    reg last1, first1, sof1;
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
                    if (lane_now == LANES - 1 || row_now == HEIGHT - 1) begin
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
        a1 <= {lane_now, bank_now} * WIDTH + col_now[XW-1:0];
        // the group's last pixel: its last line (lane LANES-1 or the frame's last row)
        last1 <= (col_now == WIDTH - 1) && (lane_now == LANES - 1 || row_now == HEIGHT - 1);
        first1 <= (col_now == 0) && (lane_now == 0);
        sof1 <= (col_now == 0) && (row_now == 0);          // the frame's first group
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
    reg v2, last2, first2, sof2, od2, og2, ox1_2, ox2_2;
    reg [D_W-1:0] d2;
    reg [G_W-1:0] g2;
    reg [AW-1:0] a2w;
    reg [LW-1:0] lane2;
    reg bank2;
    always @(posedge clk) begin
        v2 <= rst ? 1'b0 : v1;
        {d2, g2, a2w, last2, first2, sof2, lane2, bank2} <=
            {d_n, g_n, a1, last1, first1, sof1, lane1, bank1};
        {od2, og2, ox1_2, ox2_2} <= {ovf_dn, ovf_gn, ox1, ox2};
    end
    // the line buffer (p2_ram), written here, read by the sweep engine
    wire [D_W+G_W-1:0] lb_q;

    // ---- the controllers ----------------------------------------------------------------
    // Each controller's registers describe its slot of the current cycle (on, phase,
    // column, bank, buffer address); the cycle before decides them, so no decision (go)
    // and no address arithmetic lies between a register and the block RAMs' address.
    // Buffer layout: the line buffer's entry (lane, bank, column k) at (lane 2 + bank)
    // WIDTH + k, the sweep buffer's at lane WIDTH + k (bank 0) or lane WIDTH + WIDTH-1-k
    // (bank 1), concatenations when WIDTH is a power of two; the read addresses advance
    // by 2 WIDTH (line buffer) or WIDTH (sweep buffer) per lane and by one word per slot
    // (no multiply).
    reg [1:0] ready;                 // per bank: a group is in the line buffer
    reg [LW:0] lines [0:1];          // per bank: the group's lines
    reg [1:0] sof_b;                 // per bank: its group is a frame's first
    reg [1:0] lb_busy;               // per bank: its sweep has reads left
    reg [1:0] used;                  // per bank: a group of it has been swept
    reg [1:0] f_started;             // per bank: that group's forward pass has started
    reg [1:0] f_pend;                // per bank: a swept group waits for its forward pass
    // the time compares, for the cycle after next: per bank, hold_met2 = now + 2 -
    // (its forward start) >= HOLD_B, fwd_met2 = now + 2 - (its sweep's start) >= FWD_K
    // (the sweep written back); hold_a_met2 = now + 2 - (the last sweep's start) >=
    // HOLD_A. Each a down-counter of the cycles left (CW bits), loaded at its start event
    // with K - 2 and met the cycle after it reads 1: no wide compare, no absolute time
    localparam signed [47:0] FWD_K = SWEEP_LEN + T_B;
    localparam signed [47:0] K_MAX = (FWD_K > HOLD_A) ? ((FWD_K > HOLD_B) ? FWD_K : HOLD_B)
                                                      : ((HOLD_A > HOLD_B) ? HOLD_A : HOLD_B);
    localparam integer CW = $clog2(K_MAX + 1);
    localparam [CW-1:0] FWD_REM = (FWD_K > 2) ? FWD_K - 2 : 0;
    localparam [CW-1:0] HOLD_A_REM = (HOLD_A > 2) ? HOLD_A - 2 : 0;
    localparam [CW-1:0] HOLD_B_REM = (HOLD_B > 2) ? HOLD_B - 2 : 0;
    reg [1:0] hold_met2, fwd_met2;
    reg hold_a_met2;
    reg [CW-1:0] hold_rem [0:1];
    reg [CW-1:0] fwd_rem [0:1];
    reg [CW-1:0] hold_a_rem;
    integer cb;
    // the sweep's slot at this cycle: sw_go (its first), sw_on, phase ph (the lane),
    // st_t (column WIDTH-1-st_t), bank, line-buffer read address lb_ra
    reg sw_go, sw_on, sw_bank, sw_next, sw_ph_last, sw_t_last;
    reg [PBW-1:0] ph;
    reg [XW-1:0] st_t;
    reg [AW-1:0] lb_ra, lb_ca;       // the slot's address; (bank, column)'s: bank WIDTH + col
    wire sb_bank = sw_bank;
    wire [LW:0] sw_lines = lines[sb_bank];
    wire r_v = sw_on && (ph < sw_lines);
    wire [XW-1:0] r_col = WIDTH - 1 - st_t;
    wire sw_last_read = sw_on && (ph == LANES - 1) && sw_t_last;
    wire sw_wrap = sw_on && sw_ph_last;
    wire sw_end = sw_wrap && sw_t_last;
    wire sw_free = !sw_on || sw_end;            // no slot of this sweep next cycle
    // the forward pass's slot at this cycle likewise (sweep-buffer read address sb_ra)
    reg fw_go, fw_on, fw_bank, fw_next, fw_ph_last, fw_k_last;
    reg [PFW-1:0] fph;
    reg [XW-1:0] fk;
    reg [SAW-1:0] sb_ra, sb_ca;      // the slot's address; its column's, lane 0 (k, WIDTH-1-k)
    reg [LW:0] sw_lines_b [0:1];     // per bank: the lines of the group swept into it
    reg [1:0] sw_sof_b;              // per bank: that group is a frame's first
    reg [LW:0] fw_lines;
    reg fw_sof;
    wire fb = fw_bank;
    wire t_v = fw_on && (fph < fw_lines);
    wire fw_wrap = fw_on && fw_ph_last;
    wire fw_end = fw_wrap && fw_k_last;
    wire fw_free = !fw_on || fw_end;
    // next cycle's starts: the sweep when its next bank's group is in the line buffer
    // (or arrives now) and the sweep buffer's hold has passed (HOLD after the previous
    // group's forward start: HOLD_A after the previous sweep's start and HOLD_B after the
    // forward start of the group before it, in its bank); the forward pass when its next
    // bank's sweep is written back
    wire [1:0] bank2_is = {bank2, ~bank2};
    wire [1:0] ready_n = ready | ({2{v2 && last2}} & bank2_is);
    wire [1:0] fwgo_is = {2{fw_go}} & {fw_next, ~fw_next};
    wire [1:0] started_n = f_started | fwgo_is;
    wire hold_now = (HOLD_B <= 1);
    wire [1:0] hold_n = (fwgo_is & {2{hold_now}}) | (~fwgo_is & hold_met2);
    wire hold_ok_n = hold_a_met2 && (!used[sw_next] || (started_n[sw_next] && hold_n[sw_next]));
    wire sw_go_n = sw_free && ready_n[sw_next] && hold_ok_n;
    wire fw_go_n = fw_free && f_pend[fw_next] && fwd_met2[fw_next];
    // the first slot's addresses: column WIDTH-1 (the sweep) or 0 (the forward pass) of
    // lane 0 in the next bank
    wire [AW-1:0] sw_start = sw_next ? 2 * WIDTH - 1 : WIDTH - 1;
    wire [SAW-1:0] fw_start = fw_next ? WIDTH - 1 : 0;

    always @(posedge clk) begin
        if (rst) begin
            ready <= 2'b00; lb_busy <= 2'b00; used <= 2'b00; f_started <= 2'b00;
            f_pend <= 2'b00; overrun <= 1'b0;
            // no previous sweep, no forward start: no bound, the counters idle
            hold_met2 <= 2'b11; fwd_met2 <= 2'b11; hold_a_met2 <= 1'b1;
            hold_a_rem <= 0;
            for (cb = 0; cb < 2; cb = cb + 1) begin
                hold_rem[cb] <= 0; fwd_rem[cb] <= 0;
            end
            sw_go <= 1'b0; sw_on <= 1'b0; sw_bank <= 1'b0; sw_next <= 1'b0; ph <= 0;
            st_t <= 0; sw_ph_last <= (P_B == 1); sw_t_last <= (WIDTH == 1);
            fw_go <= 1'b0; fw_on <= 1'b0; fw_bank <= 1'b0; fw_next <= 1'b0; fph <= 0;
            fk <= 0; fw_ph_last <= (P_F == 1); fw_k_last <= (WIDTH == 1);
        end else begin
            // the counters count down to their compares' cycle (reloaded below where a
            // bank restarts)
            for (cb = 0; cb < 2; cb = cb + 1) begin
                if (!hold_met2[cb]) begin
                    hold_rem[cb] <= hold_rem[cb] - 1'b1;
                    hold_met2[cb] <= (hold_rem[cb] == 1);
                end
                if (!fwd_met2[cb]) begin
                    fwd_rem[cb] <= fwd_rem[cb] - 1'b1;
                    fwd_met2[cb] <= (fwd_rem[cb] == 1);
                end
            end
            if (!hold_a_met2) begin
                hold_a_rem <= hold_a_rem - 1'b1;
                hold_a_met2 <= (hold_a_rem == 1);
            end
            // the input side: a group's first pixel claims its bank, its last one is ready
            if (v2 && first2) begin
                if (lb_busy[bank2] || ready[bank2]) overrun <= 1'b1;
                lb_busy[bank2] <= 1'b1;
                sof_b[bank2] <= sof2;
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
                fwd_rem[sw_next] <= FWD_REM;
                fwd_met2[sw_next] <= (FWD_K <= 2);  // now + 2 - b_start = 2
                hold_a_rem <= HOLD_A_REM;
                hold_a_met2 <= (HOLD_A <= 2);
                sw_lines_b[sw_next] <= lines[sw_next];
                sw_sof_b[sw_next] <= sof_b[sw_next];
                sw_next <= ~sw_next;
            end
            // the sweep's next slot
            sw_go <= sw_go_n;
            sw_on <= sw_go_n || !sw_free;
            ph <= sw_wrap ? {PBW{1'b0}} : sw_on ? ph + 1'b1 : ph;
            sw_ph_last <= (sw_wrap || !sw_on) ? (P_B == 1) : (ph == P_B - 2);
            st_t <= sw_end ? {XW{1'b0}} : sw_wrap ? st_t + 1'b1 : st_t;
            sw_t_last <= sw_end ? (WIDTH == 1) : sw_wrap ? (st_t == WIDTH - 2) : sw_t_last;
            if (sw_free) begin
                sw_bank <= sw_next;
                lb_ra <= sw_start;
                lb_ca <= sw_start;
            end else if (sw_wrap) begin
                lb_ra <= lb_ca - 1'b1;
                lb_ca <= lb_ca - 1'b1;
            end else begin
                lb_ra <= lb_ra + 2 * WIDTH;
            end
            if (fw_go) begin
                f_pend[fw_next] <= 1'b0;
                f_started[fw_next] <= 1'b1;
                hold_rem[fw_next] <= HOLD_B_REM;
                hold_met2[fw_next] <= (HOLD_B <= 2);  // now + 2 - f_start = 2
                fw_next <= ~fw_next;
            end
            // the forward pass's next slot
            fw_go <= fw_go_n;
            fw_on <= fw_go_n || !fw_free;
            fph <= fw_wrap ? {PFW{1'b0}} : fw_on ? fph + 1'b1 : fph;
            fw_ph_last <= (fw_wrap || !fw_on) ? (P_F == 1) : (fph == P_F - 2);
            fk <= fw_end ? {XW{1'b0}} : fw_wrap ? fk + 1'b1 : fk;
            fw_k_last <= fw_end ? (WIDTH == 1) : fw_wrap ? (fk == WIDTH - 2) : fw_k_last;
            if (fw_free) begin
                fw_bank <= fw_next;
                fw_lines <= sw_lines_b[fw_next];
                fw_sof <= sw_sof_b[fw_next];
                sb_ra <= fw_start;
                sb_ca <= fw_start;
            end else if (fw_wrap) begin     // the next column: one word on (bank 0) or back
                sb_ra <= fb ? sb_ca - 1'b1 : sb_ca + 1'b1;
                sb_ca <= fb ? sb_ca - 1'b1 : sb_ca + 1'b1;
            end else begin
                sb_ra <= sb_ra + WIDTH;
            end
        end
    end

    // ---- the sweep engine ------------------------------------------------------------
    // r: the line-buffer read (address); a tag (valid, first slot, lane, column, bank)
    // travels beside every slot: btag(i) holds the tag of the slot read at r = now - i
    localparam integer TAGW = 2 + LW + XW + 1;
    localparam integer WB_T = SWEEP_READ + T_B;  // the write-back's tag: btag(WB_T)
    localparam integer NBT = WB_T;
    wire [TAGW-1:0] tag_r = {r_v, (st_t == 0), ph[LW-1:0], r_col, sb_bank};
    reg [TAGW*NBT-1:0] btags;
    always @(posedge clk)
        btags <= rst ? {(TAGW*NBT){1'b0}} : {btags[TAGW*(NBT-1)-1:0], tag_r};
`define P2_BTAG(i) btags[TAGW*((i)-1) +: TAGW]
`define P2_FTAG(i) ftags[FTAGW*((i)-1) +: FTAGW]
    // r+1: the address registered, r+2: the block RAMs' read, r+3: their outputs
    // registered, r+4, r+5: combined (p2_ram)
    p2_ram #(D_W + G_W, DEPTH, AW) u_lb (
        .clk(clk), .we(v2), .wa(a2w), .wd({d2, g2}), .ra(lb_ra), .zero(1'b0), .rd(lb_q));
    wire [D_W+G_W-1:0] rd2 = lb_q;
    // r+3: D = d_k + d_k+1, dG = G_k+1 - G_k (d_k+1, G_k+1 from the lane's previous slot)
    wire [TAGW-1:0] tg2 = `P2_BTAG(LB_READ);
    wire v_2 = tg2[TAGW-1];
    wire [LW-1:0] lane_2 = tg2[XW+1 +: LW];
    reg [D_W-1:0] nb_d [0:LANES-1];
    reg [G_W-1:0] nb_g [0:LANES-1];
    wire [D_W-1:0] dk = rd2[D_W+G_W-1:G_W];
    wire [G_W-1:0] gk = rd2[G_W-1:0];
    wire [D_W-1:0] dk1 = nb_d[lane_2];
    wire [G_W-1:0] gk1 = nb_g[lane_2];
    reg signed [D_W+1:0] dsum3;
    reg signed [DG_W-1:0] dg3;
    always @(posedge clk) begin
        if (v_2) begin
            nb_d[lane_2] <= dk;
            nb_g[lane_2] <= gk;
        end
        dsum3 <= $signed({{2{(D_S != 0) & dk[D_W-1]}}, dk})
               + $signed({{2{(D_S != 0) & dk1[D_W-1]}}, dk1});
        dg3 <= $signed({(G_S != 0) & gk1[G_W-1], gk1}) - $signed({(G_S != 0) & gk[G_W-1], gk});
    end
    // r+6 -> r+10: KA D (fx_mul_pipe, IREG = 1); r+11: a = cast(KA D)
    wire signed [KA_W:0] ka_s = {(KA_S != 0) & ka_raw[KA_W-1], ka_raw};
    wire signed [KA_W+D_W+2:0] ka_d;
    fx_mul_pipe #(KA_W + 1, D_W + 2, 1) m_kad (clk, ka_s, dsum3, ka_d);
    wire [A_W-1:0] a_n;
    wire ovf_an;
    fx_cast_sized #(KA_W + D_W + 3, KA_F + D_F, A_W, A_F, A_S, A_Q, A_O) c_a (
        .x(ka_d), .y(a_n), .ovf(ovf_an));
    reg [A_W-1:0] a7;
    reg oa7;
    always @(posedge clk) {a7, oa7} <= {a_n, ovf_an};
    // r+11 -> r+15: a^2; r+16: cast(a^2); r+17: c = max(cast(a^2), C_MIN), the loop entry
    wire signed [A_W:0] a7s = {(A_S != 0) & a7[A_W-1], a7};
    wire signed [2*A_W+1:0] asq;
    fx_mul_pipe #(A_W + 1, A_W + 1, 1) m_asq (clk, a7s, a7s, asq);
    wire [C_W-1:0] c_n;
    wire ovf_cn;
    fx_cast_sized #(2 * A_W + 2, 2 * A_F, C_W, C_F, C_S, C_Q, C_O) c_c (
        .x(asq), .y(c_n), .ovf(ovf_cn));
    reg [C_W-1:0] c11, cE;
    reg oc11;
    always @(posedge clk) begin
        {c11, oc11} <= {c_n, ovf_cn};
        cE <= (c11 < cmin_raw) ? cmin_raw : c11;   // unsigned (validated by the config)
    end
    // the values that travel beside the slot to the loop entry E = r + SWEEP_READ
    wire [A_W-1:0] aE;
    wire [DG_W-1:0] dgE;
    wire [DS_W-1:0] dE;
    wire oaE, ocE;
    fx_delay #(A_W + 1, SWEEP_READ - LB_READ - MUL_LAT - 2) d_aE (clk, {a7, oa7}, {aE, oaE});
    fx_delay #(DG_W, SWEEP_READ - LB_READ - 1) d_dgE (clk, dg3, dgE);
    fx_delay #(DS_W, SWEEP_READ - LB_READ - 1) d_dE (clk, dsum3[DS_W-1:0], dE);
    fx_delay #(1, SWEEP_READ - LB_READ - 2 * MUL_LAT - 3) d_ocE (clk, oc11, ocE);
    // E: the lane's S~_k+1, Q~_k+1 (its state, written at the write-back) into the
    // operand registers (E+1)
    wire [TAGW-1:0] tgE = `P2_BTAG(SWEEP_READ);
    wire [LW-1:0] lane_E = tgE[XW+1 +: LW];
    reg [ST_W-1:0] s_state [0:LANES-1];
    reg [Q_W-1:0] q_state [0:LANES-1];
    reg [ST_W-1:0] s_op1;
    reg [Q_W-1:0] q_op1;
    reg [C_W-1:0] c_op1;
    reg [DG_W-1:0] dg_op1;
    always @(posedge clk) {s_op1, q_op1, c_op1, dg_op1} <= {s_state[lane_E], q_state[lane_E], cE, dgE};
    // E+1 -> E+5: c S~, S~ dG (fx_mul_pipe, IREG = 1: the operands in the DSP at E+2)
    wire signed [ST_W:0] s_op1s = {1'b0, s_op1};
    localparam integer CS_W = C_W + ST_W + 2;
    wire signed [CS_W-1:0] cs;
    wire signed [C_W:0] c_op1s = {1'b0, c_op1};
    wire signed [DG_W-1:0] dg_op1s = dg_op1;
    fx_mul_pipe #(C_W + 1, ST_W + 1, 1) m_cs (clk, c_op1s, s_op1s, cs);
    wire signed [ST_W+DG_W:0] sdg;
    fx_mul_pipe #(ST_W + 1, DG_W, 1) m_sdg (clk, s_op1s, dg_op1s, sdg);
    wire [Q_W-1:0] q4;
    fx_delay #(Q_W, MUL_LAT) d_q4 (clk, q_op1, q4);
    // E+6: 1 + c S~, Q~ - S~ dG (one carry chain each)
    localparam integer DN_W = C_W + ST_W + 4 + F_DEN + (F_DEN - C_F - ST_F);
    localparam integer HN_W = ((Q_W + 1 + F_H - Q_F > ST_W + 1 + DG_W + F_H - ST_F - G_F)
                               ? Q_W + 1 + F_H - Q_F : ST_W + 1 + DG_W + F_H - ST_F - G_F) + 2;
    wire signed [DN_W-1:0] cs_x = cs;
    wire signed [HN_W-1:0] sdg_x = sdg;
    wire signed [HN_W-1:0] q4_x = $signed({(Q_S != 0) & q4[Q_W-1], q4});
    reg signed [DN_W-1:0] den_x5;
    reg signed [HN_W-1:0] h_x5;
    always @(posedge clk) begin
        den_x5 <= ($signed({{(DN_W-1){1'b0}}, 1'b1}) <<< F_DEN) + (cs_x <<< (F_DEN - C_F - ST_F));
        h_x5 <= (q4_x <<< (F_H - Q_F)) - (sdg_x <<< (F_H - ST_F - G_F));
    end
    // E+7 = E+E_DEN: den = cast(1 + c S~) (the divider's operand), h = cast(Q~ - S~ dG)
    wire [DEN_W-1:0] den_n;
    wire [H_W-1:0] h_n;
    wire ovf_denn, ovf_hn;
    fx_cast_sized #(DN_W, F_DEN, DEN_W, DEN_F, DEN_S, DEN_Q, DEN_O) c_den (
        .x(den_x5), .y(den_n), .ovf(ovf_denn));
    fx_cast_sized #(HN_W, F_H, H_W, H_F, H_S, H_Q, H_O) c_h (.x(h_x5), .y(h_n), .ovf(ovf_hn));
    reg [DEN_W-1:0] den6;
    reg [H_W-1:0] h6;
    reg oden6, oh6;
    always @(posedge clk) {den6, h6, oden6, oh6} <= {den_n, h_n, ovf_denn, ovf_hn};
    // E+7+T_DIV: r = divide(1, den)
    wire [R_W-1:0] r_q;
    wire ovf_rq;
    generate
        if (DIVIDER != 0) begin : g_recip
            fx_div_reciprocal #(2, 0, DEN_W + 1, DEN_F, R_W, R_F, R_S, R_Q, R_O, RECIP_L,
                                RECIP_R, ROM_FILE, 2, 1, 1) u_div (
                .clk(clk), .n(2'sb01), .d({1'b0, den6}), .y(r_q), .ovf(ovf_rq));
        end else begin : g_rest
            fx_div_restoring #(2, 0, DEN_W + 1, DEN_F, R_W, R_F, R_S, R_Q, R_O, 0) u_div (
                .clk(clk), .n(2'sb01), .d({1'b0, den6}), .y(r_q), .ovf(ovf_rq));
        end
    endgenerate
    // E+8+T_DIV: r registered (the divider's output cast apart from the products'
    // operands); E+8+T_DIV -> E+12+T_DIV: r S~_k+1, r h (fx_mul_pipe, IREG = 1)
    localparam integer RD = E_DEN + T_DIV + 1;   // r registered at E + RD
    reg [R_W-1:0] r_r;
    reg ovf_rr;
    always @(posedge clk) {r_r, ovf_rr} <= {r_q, ovf_rq};
    wire [ST_W-1:0] s_old;
    wire [H_W-1:0] h_d;
    fx_delay #(ST_W, RD - 1) d_sold (clk, s_op1, s_old);
    fx_delay #(H_W, T_DIV + 1) d_hd (clk, h6, h_d);
    wire signed [R_W:0] r_s = {(R_S != 0) & r_r[R_W-1], r_r};
    wire signed [R_W+ST_W+1:0] rs;
    wire signed [R_W+H_W+1:0] rh;
    wire signed [ST_W:0] s_old_s = {1'b0, s_old};
    wire signed [H_W:0] h_d_s = {(H_S != 0) & h_d[H_W-1], h_d};
    fx_mul_pipe #(R_W + 1, ST_W + 1, 1) m_rs (clk, r_s, s_old_s, rs);
    fx_mul_pipe #(R_W + 1, H_W + 1, 1) m_rh (clk, r_s, h_d_s, rh);
    // E+13+T_DIV: M + r S~ (one carry chain); r h waits
    localparam integer SN_W = ((MR_W + 1 + F_S - MR_F > R_W + ST_W + 2 + F_S - R_F - ST_F)
                               ? MR_W + 1 + F_S - MR_F : R_W + ST_W + 2 + F_S - R_F - ST_F) + 2;
    wire signed [SN_W-1:0] m_x = $signed({(MR_S != 0) & m_raw[MR_W-1], m_raw});
    wire signed [SN_W-1:0] rs_x = rs;
    reg signed [SN_W-1:0] s_x10;
    reg signed [R_W+H_W+1:0] rh10;
    always @(posedge clk) begin
        s_x10 <= (m_x <<< (F_S - MR_F)) + (rs_x <<< (F_S - R_F - ST_F));
        rh10 <= rh;
    end
    // E+14+T_DIV: S~_k = cast(M + r S~_k+1), Q~_k = cast(r h), registered (the casts'
    // rounding carries apart from the lane's state write)
    wire [ST_W-1:0] s_c;
    wire [Q_W-1:0] q_c;
    wire ovf_sc, ovf_qc;
    fx_cast_sized #(SN_W, F_S, ST_W, ST_F, ST_S, ST_Q, ST_O) c_s (
        .x(s_x10), .y(s_c), .ovf(ovf_sc));
    fx_cast_sized #(R_W + H_W + 2, R_F + H_F, Q_W, Q_F, Q_S, Q_Q, Q_O) c_q (
        .x(rh10), .y(q_c), .ovf(ovf_qc));
    reg [ST_W-1:0] s_n;
    reg [Q_W-1:0] q_n;
    reg ovf_sn, ovf_qn;
    always @(posedge clk) {s_n, q_n, ovf_sn, ovf_qn} <= {s_c, q_c, ovf_sc, ovf_qc};
    // E+15+T_DIV = E+T_B, the write-back: S~_k, Q~_k into the lane's state and the
    // write-back registers (taps a c den r s h q; the lane's first slot, column WIDTH-1:
    // S~_end, Q~ = 0 and the others 0)
    // beside the loop: from E (a, c, dG, D, ovf a c), E+1 (S~, Q~ operands), E+E_DEN
    // (den, h), E+RD (r) to the cycle before the write-back
    localparam integer SIDE_W = A_W + C_W + DG_W + DS_W + 2;
    wire [SIDE_W-1:0] side_E = {aE, cE, dgE, dE, oaE, ocE};
    wire [SIDE_W-1:0] side9;
    wire [ST_W+Q_W-1:0] op9;
    wire [DEN_W+H_W+1:0] dh9;
    wire [R_W:0] r9;
    fx_delay #(SIDE_W, T_B - 1) d_side (clk, side_E, side9);
    fx_delay #(ST_W + Q_W, T_B - 2) d_op (clk, {s_op1, q_op1}, op9);
    fx_delay #(DEN_W + H_W + 2, T_B - 1 - E_DEN) d_dh (clk, {den6, h6, oden6, oh6}, dh9);
    fx_delay #(R_W + 1, T_B - 1 - RD) d_r (clk, {r_r, ovf_rr}, r9);
    wire [TAGW-1:0] tg9 = `P2_BTAG(WB_T - 1);
    wire first9 = tg9[TAGW-2];
    wire [LW-1:0] lane9 = tg9[XW+1 +: LW];
    wire [ST_W-1:0] s_next = first9 ? send_raw : s_n;
    wire [Q_W-1:0] q_next = first9 ? {Q_W{1'b0}} : q_n;
    reg [ST_W-1:0] s_wb;
    reg [Q_W-1:0] q_wb;
    reg [A_W-1:0] wb_a;
    reg [C_W-1:0] wb_c;
    reg [DEN_W-1:0] wb_den;
    reg [R_W-1:0] wb_r;
    reg [H_W-1:0] wb_h;
    reg [ST_W-1:0] wb_sold;
    reg [Q_W-1:0] wb_qold;
    reg [DG_W-1:0] wb_dg;
    reg [DS_W-1:0] wb_dsum;
    reg [6:0] wb_ovf;                // a, c, den, h, r, s, q
    always @(posedge clk) begin
        s_wb <= s_next;
        q_wb <= q_next;
        if (tg9[TAGW-1]) begin
            s_state[lane9] <= s_next;
            q_state[lane9] <= q_next;
        end
        wb_a <= first9 ? {A_W{1'b0}} : side9[SIDE_W-1 -: A_W];
        wb_c <= first9 ? {C_W{1'b0}} : side9[SIDE_W-A_W-1 -: C_W];
        wb_den <= first9 ? {DEN_W{1'b0}} : dh9[DEN_W+H_W+1 -: DEN_W];
        wb_r <= first9 ? {R_W{1'b0}} : r9[R_W:1];
        wb_h <= first9 ? {H_W{1'b0}} : dh9[H_W+1 : 2];
        wb_sold <= op9[Q_W +: ST_W];
        wb_qold <= op9[Q_W-1:0];
        wb_dg <= side9[DS_W+2 +: DG_W];
        wb_dsum <= side9[2 +: DS_W];
        wb_ovf <= first9 ? 7'd0 : {side9[1], side9[0], dh9[1], dh9[0], r9[0], ovf_sn, ovf_qn};
    end
    wire [TAGW-1:0] tag_wb = `P2_BTAG(WB_T);
    wire wb_v = tag_wb[TAGW-1];
    wire [LW-1:0] wb_lane = tag_wb[XW+1 +: LW];
    // overflow counts (per signal, a slot's casts once; not the first slot's: zeroed)
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
            if (wb_v) begin
                ovf_a <= ovf_a + wb_ovf[6];
                ovf_c <= ovf_c + wb_ovf[5];
                ovf_den <= ovf_den + wb_ovf[4];
                ovf_h <= ovf_h + wb_ovf[3];
                ovf_r <= ovf_r + wb_ovf[2];
                ovf_st <= ovf_st + wb_ovf[1];
                ovf_q <= ovf_q + wb_ovf[0];
            end
        end
    end
    // the sweep buffer: entry (lane, k) = D, r, S~_k+1, Q~_k+1, dG of step k (the forward
    // pass recomputes a and |D| >= T_D from D), written at the write-back (column
    // WIDTH-1: no entry) to lane WIDTH + k (bank 0) or lane WIDTH + WIDTH-1-k (bank 1)
    reg [SAW-1:0] sb_wa;             // registered from the tag a cycle ahead
    wire sb_wbank = tg9[0];          // the write-back's group parity
    wire [XW-1:0] sb_wcol = sb_wbank ? WIDTH - 1 - tg9[1 +: XW] : tg9[1 +: XW];
    always @(posedge clk) sb_wa <= tg9[XW+1 +: LW] * WIDTH + sb_wcol;
    wire sb_zero;
    wire [SB_W-1:0] sb_q;
    p2_ram #(SB_W, SB_DEPTH, SAW) u_sb (
        .clk(clk), .we(wb_v && !tag_wb[TAGW-2]), .wa(sb_wa),
        .wd({wb_dsum, wb_r, wb_sold, wb_qold, wb_dg}), .ra(sb_ra), .zero(sb_zero),
        .rd(sb_q));

    // ---- the forward engine -----------------------------------------------------------
    // t: the sweep-buffer read (address); ftag(i) holds the tag of the slot read at
    // t = now - i: (valid, column WIDTH-1, the group's last lane, the frame's first word,
    // lane, column, bank)
    localparam integer FTAGW = 4 + LW + XW + 1;
    localparam integer NFT = FWD_READ + T_F - 2;
    wire f_zero = (fk == WIDTH - 1);
    wire [FTAGW-1:0] ftag_t = {t_v, f_zero, fph == fw_lines - 1, fw_sof && fph == 0 && fk == 0,
                               fph[LW-1:0], fk, fb};
    reg [FTAGW*NFT-1:0] ftags;
    always @(posedge clk)
        ftags <= rst ? {(FTAGW*NFT){1'b0}} : {ftags[FTAGW*(NFT-1)-1:0], ftag_t};
    // t+1: the address registered, t+2: the block RAMs' read, t+3: their outputs
    // registered; t+4, t+5 = F: combined (p2_ram; column WIDTH-1: zeros) and the e
    // operand e_k (tap e: 0 for k = 0, else the lane's state)
    wire [FTAGW-1:0] ft1 = `P2_FTAG(FWD_READ - 1);
    assign sb_zero = ft1[FTAGW-2];
    wire [SB_W-1:0] fr2 = sb_q;
    reg [E_W-1:0] e_state [0:LANES-1];
    reg [E_W-1:0] e_op;
    always @(posedge clk)
        e_op <= (ft1[1 +: XW] == 0) ? {E_W{1'b0}} : e_state[ft1[XW+1 +: LW]];
    wire [DS_W-1:0] f_dsum = fr2[SB_W-1 -: DS_W];
    wire [R_W-1:0] f_r = fr2[SB_W-DS_W-1 -: R_W];
    wire [ST_W-1:0] f_s = fr2[SB_W-DS_W-R_W-1 -: ST_W];
    wire [Q_W-1:0] f_q = fr2[DG_W +: Q_W];
    wire signed [DG_W-1:0] f_dg = fr2[0 +: DG_W];
    // F+1: u = e_k - dG (one carry chain), |D|; F+2: |D| >= T_D; F -> F+4: KA D;
    // F+5: a = cast(KA D) (as the sweep engine's; its overflow counted there); F+6: -a
    wire signed [D_W+1:0] f_ds = $signed({(D_S != 0) & f_dsum[DS_W-1], f_dsum});
    reg [D_W+1:0] fdabs_1;
    reg fthr_2;
    always @(posedge clk) begin
        fdabs_1 <= f_ds[D_W+1] ? -f_ds : f_ds;
        fthr_2 <= (fdabs_1 >= td_raw);
    end
    wire signed [KA_W+D_W+2:0] fka_d;
    fx_mul_pipe #(KA_W + 1, D_W + 2, 1) m_fkad (clk, ka_s, f_ds, fka_d);
    wire [A_W-1:0] fa_n;
    wire ovf_fan_unused;
    fx_cast_sized #(KA_W + D_W + 3, KA_F + D_F, A_W, A_F, A_S, A_Q, A_O) c_fa (
        .x(fka_d), .y(fa_n), .ovf(ovf_fan_unused));
    reg [A_W-1:0] fa5;
    always @(posedge clk) fa5 <= fa_n;
    wire signed [A_W+1:0] fa5s = $signed({(A_S != 0) & fa5[A_W-1], fa5});
    reg signed [A_W+1:0] fna6;
    always @(posedge clk) fna6 <= -fa5s;
    localparam integer U_W = ((E_W + 1 + F_U - E_F > DG_W + F_U - G_F)
                              ? E_W + 1 + F_U - E_F : DG_W + F_U - G_F) + 1;
    wire signed [U_W-1:0] e_x = $signed({(E_S != 0) & e_op[E_W-1], e_op});
    wire signed [U_W-1:0] dg_x = f_dg;
    reg signed [U_W-1:0] fu_1;
    reg [ST_W-1:0] fs_1;
    reg [Q_W-1:0] fq_1;
    reg [R_W-1:0] fr_1;
    always @(posedge clk) begin
        fu_1 <= (e_x <<< (F_U - E_F)) - (dg_x <<< (F_U - G_F));
        {fs_1, fq_1, fr_1} <= {f_s, f_q, f_r};
    end
    // F+1 -> F+5: S~_k+1 u; F+6: + Q~_k+1; F+7: w = cast(...) (tap w)
    localparam integer WN_W = ((ST_W + 1 + U_W + F_W - ST_F - F_U > Q_W + 1 + F_W - Q_F)
                               ? ST_W + 1 + U_W + F_W - ST_F - F_U : Q_W + 1 + F_W - Q_F) + 2;
    wire signed [ST_W+U_W:0] su;
    wire signed [ST_W:0] fs_1s = {1'b0, fs_1};
    fx_mul_pipe #(ST_W + 1, U_W, 1) m_su (clk, fs_1s, fu_1, su);
    wire [Q_W-1:0] q4f;
    fx_delay #(Q_W, MUL_LAT) d_q4f (clk, fq_1, q4f);
    wire signed [WN_W-1:0] su_x = su;
    wire signed [WN_W-1:0] fq_x = $signed({(Q_S != 0) & q4f[Q_W-1], q4f});
    reg signed [WN_W-1:0] w_x5;
    always @(posedge clk) w_x5 <= (su_x <<< (F_W - ST_F - F_U)) + (fq_x <<< (F_W - Q_F));
    wire [W_W-1:0] w_n;
    wire ovf_wn;
    fx_cast_sized #(WN_W, F_W, W_W, W_F, W_S, W_Q, W_O) c_w (.x(w_x5), .y(w_n), .ovf(ovf_wn));
    reg [W_W-1:0] w6;
    reg ow6;
    always @(posedge clk) {w6, ow6} <= {w_n, ovf_wn};
    // F+FO_W -> F+FO_W+4: r w; F+FO_LAM-1: its rounded value (fx_cast_reg), F+FO_LAM:
    // lam = cast(r w) (tap lam; the rounding carry and the overflow mode in two cycles)
    wire [R_W-1:0] r6;
    fx_delay #(R_W, FO_W - 1) d_r6 (clk, fr_1, r6);
    wire signed [R_W+W_W+1:0] rw;
    wire signed [R_W:0] r6s = {(R_S != 0) & r6[R_W-1], r6};
    wire signed [W_W:0] w6s = {(W_S != 0) & w6[W_W-1], w6};
    fx_mul_pipe #(R_W + 1, W_W + 1, 1) m_rw (clk, r6s, w6s, rw);
    wire [LAM_W-1:0] lam_n;
    wire ovf_lamn;
    fx_cast_reg #(R_W + W_W + 2, R_F + W_F, LAM_W, LAM_F, LAM_S, LAM_Q, LAM_O) c_lam (
        .clk(clk), .x(rw), .y(lam_n), .ovf(ovf_lamn));
    reg [LAM_W-1:0] lam_f;
    reg olam_f;
    always @(posedge clk) {lam_f, olam_f} <= {lam_n, ovf_lamn};
    // F+FO_LAM -> F+FO_LAM+4: (-a) lam; then its rounded value (fx_cast_reg), F+FO_Z:
    // z = cast(-(a lam)) (tap z; the rounding carry and the overflow mode in two cycles)
    wire [A_W+1:0] na_l;
    fx_delay #(A_W + 2, FO_LAM - MUL_LAT - 2) d_na_l (clk, fna6, na_l);
    wire signed [A_W+LAM_W+2:0] nalam;
    wire signed [A_W+1:0] na_ls = na_l;
    wire signed [LAM_W:0] lam_fs = {(LAM_S != 0) & lam_f[LAM_W-1], lam_f};
    fx_mul_pipe #(A_W + 2, LAM_W + 1, 1) m_alam (clk, na_ls, lam_fs, nalam);
    wire [Z_W-1:0] z_n;
    wire ovf_zn;
    fx_cast_reg #(A_W + LAM_W + 3, A_F + LAM_F, Z_W, Z_F, Z_S, Z_Q, Z_O) c_z (
        .clk(clk), .x(nalam), .y(z_n), .ovf(ovf_zn));
    reg [Z_W-1:0] z_f;
    reg oz_f;
    always @(posedge clk) {z_f, oz_f} <= {z_n, ovf_zn};
    // F+FO_Z -> F+FO_Z+4: a z; F+FO_E-1: u + a z (one carry chain); its cast e_k+1,
    // registered at F+FO_E, is written into the lane's e state (read for the lane's next
    // slot at t' + 4)
    wire [A_W+1:0] a_z;
    fx_delay #(A_W + 2, FO_Z - MUL_LAT - 1) d_a_z (clk, fa5s, a_z);
    wire signed [Z_W:0] z_fs = {(Z_S != 0) & z_f[Z_W-1], z_f};
    wire signed [A_W+Z_W+2:0] az;
    wire signed [A_W+1:0] a_zs = a_z;
    fx_mul_pipe #(A_W + 2, Z_W + 1, 1) m_az (clk, a_zs, z_fs, az);
    wire [U_W-1:0] u_az;
    fx_delay #(U_W, FO_Z + MUL_LAT - 1) d_u_az (clk, fu_1, u_az);
    localparam integer EN_W = ((U_W + F_E - F_U > A_W + Z_W + 3 + F_E - A_F - Z_F)
                               ? U_W + F_E - F_U : A_W + Z_W + 3 + F_E - A_F - Z_F) + 2;
    wire signed [EN_W-1:0] az_x = az;
    wire signed [EN_W-1:0] u_az_x = $signed(u_az);
    reg signed [EN_W-1:0] e_sum;
    always @(posedge clk) e_sum <= (u_az_x <<< (F_E - F_U)) + (az_x <<< (F_E - A_F - Z_F));
    wire [E_W-1:0] e_new;
    wire ovf_en;
    fx_cast_sized #(EN_W, F_E, E_W, E_F, E_S, E_Q, E_O) c_e (.x(e_sum), .y(e_new), .ovf(ovf_en));
    // F+FO_E: the cast registered (its rounding carry apart from the lane's e state
    // write), written into the lane's e state at the end of F+FO_E
    reg [E_W-1:0] e_f;
    reg oe_f;
    always @(posedge clk) {e_f, oe_f} <= {e_new, ovf_en};
    wire [FTAGW-1:0] ft_st = `P2_FTAG(FWD_READ + FO_E);
    always @(posedge clk) if (ft_st[FTAGW-1]) e_state[ft_st[XW+1 +: LW]] <= e_f;
    // F+FO_Z+1: valid, range (threshold); F+FO_Z+2: the output register
    wire [0:0] thr_z;
    fx_delay #(1, FO_Z - 2) d_thr_z (clk, fthr_2, thr_z);
    wire signed [Z_W:0] rmax_s = {(Z_S != 0) & rmax_raw[Z_W-1], rmax_raw};
    wire ok_z = thr_z[0] && (z_fs > 0) && (z_fs <= rmax_s);
    reg valid_f;
    reg [Z_W-1:0] range_f;
    always @(posedge clk) begin
        valid_f <= ok_z;
        range_f <= ok_z ? z_f : rmax_raw;
    end
    // the taps' valid strobes (one register each, one sample per cycle)
    wire [FTAGW-1:0] ft_e = `P2_FTAG(FWD_READ);
    wire [FTAGW-1:0] ft_w = `P2_FTAG(FWD_READ + FO_W);
    wire [FTAGW-1:0] ft_lam = `P2_FTAG(FWD_READ + FO_LAM);
    wire [FTAGW-1:0] ft_z = `P2_FTAG(FWD_READ + FO_Z);
    wire [FTAGW-1:0] ft_vr = `P2_FTAG(FWD_READ + FO_Z + 1);
    wire tap_e_v = ft_e[FTAGW-1];
    wire tap_w_v = ft_w[FTAGW-1];
    wire tap_lam_v = ft_lam[FTAGW-1];
    wire tap_z_v = ft_z[FTAGW-1];
    always @(posedge clk) begin
        if (rst) begin
            ovf_w <= 0; ovf_lam <= 0; ovf_z <= 0; ovf_e <= 0;
        end else begin
            if (tap_w_v && !ft_w[FTAGW-2]) ovf_w <= ovf_w + ow6;
            if (tap_lam_v && !ft_lam[FTAGW-2]) ovf_lam <= ovf_lam + olam_f;
            if (tap_z_v && !ft_z[FTAGW-2]) ovf_z <= ovf_z + oz_f;
            if (ft_st[FTAGW-1] && !ft_st[FTAGW-2]) ovf_e <= ovf_e + oe_f;
        end
    end
    // F+FO_Z+2: the output register (taps valid, range; m_axis): TUSER on each frame's
    // first word (lane 0, column 0 of its first group), TLAST on the group's last (its
    // last lane, column WIDTH-1)
    always @(posedge clk) begin
        m_axis_tvalid <= rst ? 1'b0 : ft_vr[FTAGW-1];
        m_axis_tdata <= {valid_f, range_f};
        m_axis_tuser <= ft_vr[FTAGW-1] && ft_vr[FTAGW-4];
        m_axis_tlast <= ft_vr[FTAGW-1] && ft_vr[FTAGW-3] && (ft_vr[1 +: XW] == WIDTH - 1);
    end
`undef P2_BTAG
`undef P2_FTAG
endmodule

// p2_ram: P2's line and sweep buffers, DEPTH words of W bits (one write port, one read
// port), built of blocks of BLK words, one block RAM deep each (a DP16KD holds 1024 x 18).
// A read's address at cycle r is registered with its one-hot block select (r + 1, the
// block RAMs' address); at r + 2 each block's read port holds its word if the block holds
// the address, else zero (the block RAM's synchronous read reset); at r + 3 each block's
// word in a register beside it; at r + 4 the blocks' words ORed in fours; at r + 5
// (RD = 5) those ORed, or zero if `zero` (sampled at r + 4). A write (at cycle w) is
// registered likewise and written at the end of w + 1, so reads and writes keep their
// order. No path holds more than a block RAM's clock-to-out, a register's fan-out to the
// blocks, or a route across the die and one or two LUTs: one inferred RAM of the whole
// depth would select among its blocks' outputs in the cycle of the read (25 blocks deep
// at 512 wide), after the address arithmetic; the ORs straight after the block RAMs'
// outputs (their clock-to-out 4.3 ns at speed 8) ran at 103.9 MHz at 512 wide.
// With RANGEFX_ECP5_DSP defined (the timing flow, tools/studies/timing.py; as fx_mul18)
// each block is ceil(W / 18) DP16KD (p2_dp16kd, 1024 x 18) and the register at r + 3 is
// the DP16KD's own output register (REGMODE "OUTREG"), zeroed by its synchronous reset
// from the block select registered once more: the same words at the same cycles, and no
// route leaves a block RAM before a register. Yosys's ECP5 memory mapping does not use
// the output register, so the behavioural body (Icarus, Verilator, `hdl synth`) infers
// the read-reset RAM and the register beside it.
module p2_ram #(
    parameter integer W = 18,
    parameter integer DEPTH = 1024,
    parameter integer AW = 10,          // address bits, $clog2(DEPTH)
    parameter integer BLK = 1024        // at most 1024 (a DP16KD in 1024 x 18)
) (
    input  wire          clk,
    input  wire          we,
    input  wire [AW-1:0] wa,
    input  wire [W-1:0]  wd,
    input  wire [AW-1:0] ra,
    input  wire          zero,
    output reg  [W-1:0]  rd
);
    localparam integer BK = (DEPTH < BLK) ? DEPTH : BLK;    // words per block
    localparam integer BW = (BK > 1) ? $clog2(BK) : 1;
    localparam integer NB = (DEPTH + BK - 1) / BK;
    localparam integer NG = (NB + 3) / 4;
    localparam integer XW = AW + BW + 1;
    localparam integer NS = (W + 17) / 18;               // DP16KD (1024 x 18) per block
    wire [XW-1:0] wax = wa;
    wire [XW-1:0] rax = ra;
    // r + 1 (w + 1): the addresses, the write data, per block its write enable and
    // whether it is not the one read
    reg [BW-1:0] ra1, wa1;
    reg [W-1:0] wd1;
    reg [NB-1:0] we1, nsel1;
    integer b;
    always @(posedge clk) begin
        {ra1, wa1, wd1} <= {rax[BW-1:0], wax[BW-1:0], wd};
        for (b = 0; b < NB; b = b + 1) begin
            we1[b] <= we && (wax >> BW) == b;
            nsel1[b] <= (rax >> BW) != b;
        end
    end
    wire [W*4*NG-1:0] q;                // every block's word, zero beyond the last block
    wire [W*NG-1:0] og;
    genvar i, g, s;
    generate
        for (i = 0; i < 4 * NG; i = i + 1) begin : g_blk
            if (i < NB) begin : g_ram
`ifdef RANGEFX_ECP5_DSP
                // r + 2: the DP16KD's read latch, r + 3: its output register, zeroed when
                // the block was not the one read (nsel2: the select at r + 2)
                reg nsel2;
                always @(posedge clk) nsel2 <= nsel1[i];
                wire [18*NS-1:0] wdx = wd1;
                wire [18*NS-1:0] qx;
                for (s = 0; s < NS; s = s + 1) begin : g_slice
                    p2_dp16kd #(.BW(BW)) u_bram (
                        .clk(clk), .we(we1[i]), .wa(wa1), .wd(wdx[18*s +: 18]), .ra(ra1),
                        .rst(nsel2), .q(qx[18*s +: 18]));
                end
                assign q[W*i +: W] = qx[W-1:0];
`else
                reg [W-1:0] mem [0:BK-1];
                reg [W-1:0] qr, qb;
                always @(posedge clk) begin
                    if (we1[i]) mem[wa1] <= wd1;
                    if (nsel1[i]) qr <= {W{1'b0}};
                    else qr <= mem[ra1];
                    qb <= qr;
                end
                assign q[W*i +: W] = qb;
`endif
            end else begin : g_none
                assign q[W*i +: W] = {W{1'b0}};
            end
        end
        for (g = 0; g < NG; g = g + 1) begin : g_or
            reg [W-1:0] o;
            always @(posedge clk)
                o <= q[W*(4*g) +: W] | q[W*(4*g+1) +: W] | q[W*(4*g+2) +: W] | q[W*(4*g+3) +: W];
            assign og[W*g +: W] = o;
        end
    endgenerate
    reg [W-1:0] acc;
    integer k;
    always @* begin
        acc = {W{1'b0}};
        for (k = 0; k < NG; k = k + 1) acc = acc | og[W*k +: W];
    end
    always @(posedge clk) rd <= zero ? {W{1'b0}} : acc;
endmodule

`ifdef RANGEFX_ECP5_DSP
// p2_dp16kd: one ECP5 DP16KD as a 1024 x 18 simple dual-port RAM (timing flow only):
// port A writes `wd` at `wa` when `we`; port B reads `ra`, its word in the output
// register (REGMODE_B "OUTREG") two clock edges after the address, zero instead when
// `rst` (synchronous) is high at the second edge. In x18 mode the word address is on
// AD13..AD4, AD1..AD0 are the write's byte enables.
module p2_dp16kd #(
    parameter integer BW = 10           // address bits used (blocks under 1024 words)
) (
    input  wire          clk,
    input  wire          we,
    input  wire [BW-1:0] wa,
    input  wire [17:0]   wd,
    input  wire [BW-1:0] ra,
    input  wire          rst,
    output wire [17:0]   q
);
    wire [9:0] a = wa;
    wire [9:0] b = ra;
    DP16KD #(
        .DATA_WIDTH_A(18), .DATA_WIDTH_B(18), .REGMODE_A("NOREG"), .REGMODE_B("OUTREG"),
        .RESETMODE("SYNC"), .ASYNC_RESET_RELEASE("SYNC"), .CSDECODE_A("0b000"),
        .CSDECODE_B("0b000"), .WRITEMODE_A("NORMAL"), .WRITEMODE_B("NORMAL"),
        .GSR("DISABLED")
    ) u_ebr (
        .CLKA(clk), .CEA(1'b1), .OCEA(1'b1), .WEA(we), .RSTA(1'b0),
        .CSA0(1'b0), .CSA1(1'b0), .CSA2(1'b0),
        .ADA0(1'b1), .ADA1(1'b1), .ADA2(1'b0), .ADA3(1'b0),
        .ADA4(a[0]), .ADA5(a[1]), .ADA6(a[2]), .ADA7(a[3]), .ADA8(a[4]), .ADA9(a[5]),
        .ADA10(a[6]), .ADA11(a[7]), .ADA12(a[8]), .ADA13(a[9]),
        .DIA0(wd[0]), .DIA1(wd[1]), .DIA2(wd[2]), .DIA3(wd[3]), .DIA4(wd[4]),
        .DIA5(wd[5]), .DIA6(wd[6]), .DIA7(wd[7]), .DIA8(wd[8]), .DIA9(wd[9]),
        .DIA10(wd[10]), .DIA11(wd[11]), .DIA12(wd[12]), .DIA13(wd[13]), .DIA14(wd[14]),
        .DIA15(wd[15]), .DIA16(wd[16]), .DIA17(wd[17]),
        .CLKB(clk), .CEB(1'b1), .OCEB(1'b1), .WEB(1'b0), .RSTB(rst),
        .CSB0(1'b0), .CSB1(1'b0), .CSB2(1'b0),
        .ADB0(1'b0), .ADB1(1'b0), .ADB2(1'b0), .ADB3(1'b0),
        .ADB4(b[0]), .ADB5(b[1]), .ADB6(b[2]), .ADB7(b[3]), .ADB8(b[4]), .ADB9(b[5]),
        .ADB10(b[6]), .ADB11(b[7]), .ADB12(b[8]), .ADB13(b[9]),
        .DIB0(1'b0), .DIB1(1'b0), .DIB2(1'b0), .DIB3(1'b0), .DIB4(1'b0), .DIB5(1'b0),
        .DIB6(1'b0), .DIB7(1'b0), .DIB8(1'b0), .DIB9(1'b0), .DIB10(1'b0), .DIB11(1'b0),
        .DIB12(1'b0), .DIB13(1'b0), .DIB14(1'b0), .DIB15(1'b0), .DIB16(1'b0),
        .DIB17(1'b0),
        .DOB0(q[0]), .DOB1(q[1]), .DOB2(q[2]), .DOB3(q[3]), .DOB4(q[4]), .DOB5(q[5]),
        .DOB6(q[6]), .DOB7(q[7]), .DOB8(q[8]), .DOB9(q[9]), .DOB10(q[10]),
        .DOB11(q[11]), .DOB12(q[12]), .DOB13(q[13]), .DOB14(q[14]), .DOB15(q[15]),
        .DOB16(q[16]), .DOB17(q[17]));
endmodule
`endif
