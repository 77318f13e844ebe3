// p1_div_recip: pipelined reciprocal divider `divide(N, D, S)` of rangefx: seed ROM plus
// one Newton step (docs/p1_datapath.md "Dividers", rtl_model/p1/model.py divide_scalar),
// one division per clock, latency 8 (rtl_model/runtime.py RECIPROCAL_LATENCY):
//   1  normalise: p = bitlen(|D|) - 1 by a priority encoder, |D| shifted to put its
//      leading one at bit D_W - 1; idx (the L bits after the leading one) reads the
//      seed ROM (ROM_FILE: the vectors' recip_rom.mem, 2^L words) -> y0; mR = m 2^R
//   2-3 t = (mR y0) >> R, e = 2^(R+1) - t
//   4-5 y1 = (y0 e) >> R
//   6   |N| y1
//   7   the product shifted left by D_W - 1 - p (so that the final cast's shift is a
//       constant), and the sign sign(N) sign(D)
//   8   cast of that value 2^-(F_N - F_D + D_W - 1 + R) into S; D = 0 gives 0 for N = 0,
//       else S's overflow mode acting on an infinite value of N's sign (counted).
`timescale 1ns / 1ps
module p1_div_recip #(
    parameter integer N_W = 40, parameter integer N_F = 21, parameter integer N_S = 1,
    parameter integer D_W = 20, parameter integer D_F = 11, parameter integer D_S = 0,
    parameter integer Q_W = 24, parameter integer Q_F = 12, parameter integer Q_S = 1,
    parameter integer Q_Q = 2,  parameter integer Q_O = 1,
    parameter integer L = 8,    // recip_lut_bits
    parameter integer R = 20,   // recip_bits
    parameter ROM_FILE = "recip_rom.mem"
) (
    input  wire           clk,
    input  wire [N_W-1:0] n,
    input  wire [D_W-1:0] d,
    output reg  [Q_W-1:0] q,
    output reg            ovf
);
    localparam integer PMAX = D_W - 1;
    localparam integer K = (L > R) ? L : R;
    localparam integer AW = D_W + K;                 // normalised |D| with K bits below
    localparam integer PB = (D_W > 1) ? $clog2(D_W) : 1;
    localparam integer YW = R + 1;                   // y0 < 2^R
    localparam integer TW = R + 2;                   // t, e
    localparam integer Y1W = R + 3;
    localparam integer RAWW = N_W + Y1W;             // |N| y1
    localparam integer OW = RAWW + PMAX + 1;         // shifted, signed
    localparam integer OF = N_F - D_F + PMAX + R;    // its fraction bits

    reg [YW-1:0] rom [0:(1 << L) - 1];
    initial $readmemh(ROM_FILE, rom);

    // ---- stage 1: normalise, seed --------------------------------------------------------
    wire n_neg = (N_S != 0) && n[N_W-1];
    wire d_neg = (D_S != 0) && d[D_W-1];
    wire [N_W-1:0] an = n_neg ? -n : n;
    wire [D_W-1:0] ad = d_neg ? -d : d;
    reg  [PB-1:0] p;
    integer b;
    always @* begin
        p = {PB{1'b0}};
        for (b = 0; b < D_W; b = b + 1)
            if (ad[b]) p = b;
    end
    wire [PB-1:0] lsh = PMAX - p;
    wire [AW-1:0] aj = {ad, {K{1'b0}}} << lsh;       // leading one at bit AW - 1
    wire [L-1:0] idx = aj[AW-2 -: L];
    wire [R:0] m_r = aj[AW-1 -: R + 1];
    reg [YW-1:0] y0_1;
    reg [R:0]    mr_1;
    reg [N_W-1:0] an_1;
    reg [PB-1:0] lsh_1;
    reg          neg_1, dz_1, nneg_1;
    always @(posedge clk) begin
        y0_1 <= rom[idx];
        mr_1 <= m_r;
        an_1 <= an;
        lsh_1 <= lsh;
        neg_1 <= n_neg ^ d_neg;
        dz_1 <= ad == {D_W{1'b0}};
        nneg_1 <= n_neg;
    end

    // ---- stages 2..7 ---------------------------------------------------------------------
    reg [2*R+1:0] t_2;
    reg [TW-1:0]  e_3;
    reg [YW+TW-1:0] y_4;
    reg [Y1W-1:0] y1_5;
    reg [RAWW-1:0] raw_6;
    reg signed [OW-1:0] val_7;
    reg [YW-1:0] y0_2, y0_3;
    reg [N_W-1:0] an_2, an_3, an_4, an_5;
    reg [PB-1:0] lsh_2, lsh_3, lsh_4, lsh_5, lsh_6;
    reg [5:0] neg_d, dz_d, nneg_d;   // stages 2..7
    wire [TW-1:0] two_r1 = {2'b10, {R{1'b0}}};   // 2^(R+1)
    wire [OW-1:0] raw_sh = {{(OW-RAWW){1'b0}}, raw_6} << lsh_6;
    always @(posedge clk) begin
        t_2 <= mr_1 * y0_1;
        y0_2 <= y0_1; an_2 <= an_1; lsh_2 <= lsh_1;
        e_3 <= two_r1 - t_2[R +: TW];
        y0_3 <= y0_2; an_3 <= an_2; lsh_3 <= lsh_2;
        y_4 <= y0_3 * e_3;
        an_4 <= an_3; lsh_4 <= lsh_3;
        y1_5 <= y_4[R +: Y1W];
        an_5 <= an_4; lsh_5 <= lsh_4;
        raw_6 <= an_5 * y1_5;
        lsh_6 <= lsh_5;
        val_7 <= neg_d[4] ? -$signed(raw_sh) : $signed(raw_sh);
        neg_d <= {neg_d[4:0], neg_1};
        dz_d <= {dz_d[4:0], dz_1};
        nneg_d <= {nneg_d[4:0], nneg_1};
    end

    // ---- stage 8: the cast; D = 0 ----------------------------------------------------------
    wire [Q_W-1:0] y, y_inf;
    wire           y_ovf, inf_ovf;
    fx_cast_sized #(OW, OF, 1, Q_W, Q_F, Q_S, Q_Q, Q_O) c_out (
        .x(val_7), .y(y), .ovf(y_ovf));
    // an infinite quotient of N's sign: a value beyond every Q_W-bit code
    wire signed [Q_W+2:0] inf = nneg_d[5] ? {3'b110, {Q_W{1'b0}}} : {3'b010, {Q_W{1'b0}}};
    fx_cast_sized #(Q_W + 3, Q_F, 1, Q_W, Q_F, Q_S, Q_Q, Q_O) c_inf (
        .x(inf), .y(y_inf), .ovf(inf_ovf));
    wire n_zero7 = val_7 == {OW{1'b0}};
    always @(posedge clk) begin
        if (dz_d[5]) begin
            q <= n_zero7 ? {Q_W{1'b0}} : y_inf;
            ovf <= !n_zero7 && inf_ovf;
        end else begin
            q <= y;
            ovf <= y_ovf;
        end
    end
endmodule
