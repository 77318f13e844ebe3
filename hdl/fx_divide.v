// Pipelined dividers of rangefx: divide(N, D, S) of docs/p1_datapath.md "Dividers".
//
// N and D are two's complement raw values (N_W, D_W bits) with N_F, D_F fraction bits;
// the quotient is cast into S = (OUT_S, OUT_W, OUT_F) with the modes QUANT / OVF
// (fx_cast_sized.v). One division enters per clock; the result leaves a fixed number of
// cycles later (rtl_model/runtime.py divider_latency): the pipeline advances every
// clock, the caller carries its own valid bit beside it.
//   fx_div_restoring : radix-2 restoring, sign-magnitude, OUT_W + 1 quotient bits (one
//                      per stage) with the guard bit, a sticky bit; latency OUT_W + 4
//                      (+ FRONT: the operands' magnitudes registered first)
//   fx_div_reciprocal: seed ROM (2^L words, $readmemh of ROM_FILE, a two-cycle read:
//                      address and data out registered) + one Newton step, three
//                      products, a normalising cast; latency 9 (+ 10 with PIPE = 1:
//                      the magnitudes, the leading one and the seed index each registered
//                      (+3), the products in 3 stages each (fx_mul_pipe, +6), the cast's
//                      shift registered before its rounding (+1); + 14 with PIPE = 2:
//                      the same with products of 4 stages, their operands registered in
//                      the DSP (fx_mul_pipe IREG, +9), and the cast's rounded value
//                      registered before its overflow mode (+2)); UNIT = 1 (a reciprocal:
//                      n = 1 and d >= 0, the caller's promise) leaves out the magnitude
//                      stage (PIPE != 0: -1), the |N| y1 product (-ML) and the y1
//                      register (-1): latency 7, PIPE = 1: 14, PIPE = 2: 17; NORM = 1
//                      (with PIPE != 0) splits the normalising shift of |D| in two
//                      stages (its high amount bits, registered, then its low ones: + 1)
//                      and with UNIT keeps the operand stage, D registered before its
//                      leading one (+ 1): PIPE = 1, UNIT = 1, NORM = 1: 16; NORM = 0 (the
//                      default) is the circuit without them
//   fx_lead_one      : the reciprocal's leading one of |D| (combinational), a balanced tree
// P1 (p1_range.v, p1_frontend.v) uses FRONT = 1 / PIPE = 2 to close its clock (docs/hdl.md);
// P2 (p2_top.v, r = 1/den) PIPE = 2 / UNIT = 1 / NORM = 1.
// D = 0 gives 0 when N = 0, otherwise the overflow mode of S acting on an infinite value
// with the sign of N (ovf = 1).
`timescale 1ns / 1ps

module fx_div_restoring #(
    parameter integer N_W = 16, parameter integer N_F = 0,
    parameter integer D_W = 16, parameter integer D_F = 0,
    parameter integer OUT_W = 16, parameter integer OUT_F = 0, parameter integer OUT_S = 1,
    parameter integer QUANT = 2, parameter integer OVF = 1,
    parameter integer FRONT = 0         // 1: |N|, |D| registered first (latency + 1)
) (
    input  wire                    clk,
    input  wire signed [N_W-1:0]   n,
    input  wire signed [D_W-1:0]   d,
    output reg         [OUT_W-1:0] y,
    output reg                     ovf
);
    // T = |N| 2^SH and DD = |D| 2^-SH (whichever exponent is >= 0): q = floor(T / DD) has
    // one guard bit below the LSB of S; q >= 2^QB overflows S in every mode, so only QB
    // quotient bits are computed, after a comparison that flags the overflow.
    localparam integer SH = OUT_F + 1 + D_F - N_F;
    localparam integer SHN = (SH > 0) ? SH : 0;
    localparam integer SHD = (SH < 0) ? -SH : 0;
    localparam integer QB = OUT_W + 1;
    localparam integer TW = N_W + SHN;
    localparam integer DW = D_W + SHD;
    localparam integer RW = DW + QB;            // remainder bits (R < DD 2^QB)
    localparam integer CW = ((TW > RW) ? TW : RW) + 1;
    localparam integer MW = QB + 2;             // magnitude 2q + sticky

    wire [N_W-1:0] an_n = n[N_W-1] ? -n : n;
    wire [D_W-1:0] ad_n = d[D_W-1] ? -d : d;
    wire [N_W-1:0] an;
    wire [D_W-1:0] ad;
    wire           dz, nz, sn, sd;
    generate
        if (FRONT != 0) begin : g_front
            reg [N_W-1:0] an_r;
            reg [D_W-1:0] ad_r;
            reg           dz_r, nz_r, sn_r, sd_r;
            always @(posedge clk) begin
                {an_r, ad_r} <= {an_n, ad_n};
                dz_r <= (d == {D_W{1'b0}});
                nz_r <= (n != {N_W{1'b0}});
                {sn_r, sd_r} <= {n[N_W-1], d[D_W-1]};
            end
            assign {an, ad, dz, nz, sn, sd} = {an_r, ad_r, dz_r, nz_r, sn_r, sd_r};
        end else begin : g_direct
            assign {an, ad} = {an_n, ad_n};
            assign dz = (d == {D_W{1'b0}});
            assign nz = (n != {N_W{1'b0}});
            assign {sn, sd} = {n[N_W-1], d[D_W-1]};
        end
    endgenerate
    wire [CW-1:0]  t  = {{(CW-N_W){1'b0}}, an} << SHN;
    wire [CW-1:0]  dd = {{(CW-D_W){1'b0}}, ad} << SHD;
    wire           big = dz ? nz : (t >= (dd << QB));

    // stage 0: operands; stages 1..QB: one quotient bit each (MSB first). Stage k's
    // registers sit at slice k of these buses.
    wire [RW*(QB+1)-1:0] rem_b;
    wire [DW*(QB+1)-1:0] div_b;
    wire [QB*(QB+1)-1:0] quo_b;
    wire [QB:0]          neg_b, sat_b, zer_b;
    reg  [RW-1:0] rem0;
    reg  [DW-1:0] div0;
    reg           neg0, sat0, zer0;
    always @(posedge clk) begin
        rem0 <= (big | dz) ? {RW{1'b0}} : t[RW-1:0];
        div0 <= dd[DW-1:0];
        neg0 <= dz ? sn : sn ^ sd;
        sat0 <= big;
        zer0 <= dz;
    end
    assign rem_b[RW-1:0] = rem0;
    assign div_b[DW-1:0] = div0;
    assign quo_b[QB-1:0] = {QB{1'b0}};
    assign {neg_b[0], sat_b[0], zer_b[0]} = {neg0, sat0, zer0};
    genvar k;
    generate
        for (k = 1; k <= QB; k = k + 1) begin : g_bit
            wire [RW-1:0] r_in = rem_b[(k-1)*RW +: RW];
            wire [DW-1:0] d_in = div_b[(k-1)*DW +: DW];
            wire [RW:0]   trial = {1'b0, r_in} - ({{(RW+1-DW){1'b0}}, d_in} << (QB - k));
            wire          bit_k = ~trial[RW] & ~zer_b[k-1];
            reg  [RW-1:0] r;
            reg  [DW-1:0] dv;
            reg  [QB-1:0] q;
            reg           ng, st, zr;
            always @(posedge clk) begin
                r  <= trial[RW] ? r_in : trial[RW-1:0];
                dv <= d_in;
                q  <= quo_b[(k-1)*QB +: QB] | ({{(QB-1){1'b0}}, bit_k} << (QB - k));
                {ng, st, zr} <= {neg_b[k-1], sat_b[k-1], zer_b[k-1]};
            end
            assign rem_b[k*RW +: RW] = r;
            assign div_b[k*DW +: DW] = dv;
            assign quo_b[k*QB +: QB] = q;
            assign {neg_b[k], sat_b[k], zer_b[k]} = {ng, st, zr};
        end
    endgenerate
    // stage QB+1: magnitude 2q + sticky (q clamped at 2^QB on overflow)
    reg [MW-1:0] mag;
    reg          neg_m;
    always @(posedge clk) begin
        mag <= sat_b[QB] ? ({{(MW-1){1'b0}}, 1'b1} << (QB + 1))
                         : {1'b0, quo_b[QB*QB +: QB], (rem_b[QB*RW +: RW] != {RW{1'b0}})};
        neg_m <= neg_b[QB];
    end
    // stage QB+2: sign and the cast of (2q + t) 2^-(OUT_F + 2) into S
    wire signed [MW:0]  raw = neg_m ? -$signed({1'b0, mag}) : $signed({1'b0, mag});
    wire [OUT_W-1:0] y_c;
    wire             ovf_c;
    fx_cast_sized #(MW + 1, OUT_F + 2, OUT_W, OUT_F, OUT_S, QUANT, OVF) u_cast (
        .x(raw), .y(y_c), .ovf(ovf_c));
    always @(posedge clk) {y, ovf} <= {y_c, ovf_c};
endmodule

module fx_div_reciprocal #(
    parameter integer N_W = 16, parameter integer N_F = 0,
    parameter integer D_W = 16, parameter integer D_F = 0,
    parameter integer OUT_W = 16, parameter integer OUT_F = 0, parameter integer OUT_S = 1,
    parameter integer QUANT = 2, parameter integer OVF = 1,
    parameter integer L = 8,            // seed ROM index bits (recip_lut_bits)
    parameter integer R = 20,           // reciprocal fraction bits (recip_bits)
    parameter ROM_FILE = "recip_rom.mem",
    parameter integer PIPE = 0,         // 1: + 10 stages, 2: + 14, see above
    parameter integer UNIT = 0,         // 1: y = 1/d (n = 1, d >= 0): fewer stages, above
    parameter integer NORM = 0          // 1 (PIPE != 0): + 1 or 2 stages, above
) (
    input  wire                    clk,
    input  wire signed [N_W-1:0]   n,
    input  wire signed [D_W-1:0]   d,
    output reg         [OUT_W-1:0] y,
    output reg                     ovf
);
    localparam integer YW = R + 1;      // y0 < 2^R
    localparam integer EW = R + 2;      // e = 2^(R+1) - t in (0, 2^(R+1)]
    localparam integer Y1W = R + 3;
    localparam integer PW = N_W + Y1W;  // |N| y1
    localparam integer PB = (D_W > 1) ? $clog2(D_W) : 1;  // bits of p = bitlen(|D|) - 1
    // the final cast drops F_N - F_D + p + R - OUT_F bits: a constant part SH0 plus p,
    // made non-negative by a constant left shift SHL0 of the product
    localparam integer SH0 = N_F - D_F + R - OUT_F;
    localparam integer SHL0 = (SH0 < 0) ? -SH0 : 0;
    localparam integer SH_MAX = SH0 + SHL0 + D_W - 1;
    localparam integer SH_W = (SH_MAX > 0) ? $clog2(SH_MAX + 1) : 1;
    localparam integer XW0 = PW + 1 + SHL0;
    localparam integer XW = (XW0 > OUT_W + 2) ? XW0 : OUT_W + 2;

    reg [YW-1:0] rom [0:(1 << L) - 1];
    initial $readmemh(ROM_FILE, rom);

    // stages 1-2: magnitude, leading one p, the L seed index bits and mR, the ROM read
    // (two cycles). PIPE cuts the part before the read in three: |N| |D|; p; idx and mR
    // (NORM: in four, the shift's high bits registered before idx and mR).
    wire [N_W-1:0] an_n = n[N_W-1] ? -n : n;
    wire [D_W-1:0] ad_n = (UNIT == 0 && d[D_W-1]) ? -d : d;
    wire           dz_n = (d == {D_W{1'b0}});
    wire           neg_n = (UNIT != 0) ? 1'b0 : dz_n ? n[N_W-1] : n[N_W-1] ^ d[D_W-1];
    wire           nz_n = (UNIT != 0) | (n != {N_W{1'b0}});
    wire [N_W-1:0] an, an_b, an_c;     // after cut a (|N| |D|), b (p), c (idx, mR)
    wire [D_W-1:0] ad, ad_b;
    wire [2:0]     fl, fl_b, fl_c;     // neg, dz, nz
    wire [PB-1:0]  p, p_c;
    wire [L-1:0]   idx, idx_c;
    wire [R:0]     mr, mr_c;
    wire [PB-1:0]  p_n;
    fx_lead_one #(.W(D_W), .PB(PB)) u_lead (.a(ad), .p(p_n));
    wire [D_W-1:0] aligned;                         // leading one at bit D_W - 1
    wire [N_W-1:0] an_s;                            // beside the shift (NORM: its cut)
    wire [2:0]     fl_s;
    wire [PB-1:0]  p_s;
    // idx = floor(|D| 2^(L-p)) - 2^L, mR = floor(|D| 2^(R-p)): constant shifts of `aligned`
    wire [D_W+L-1:0] idx_w = {aligned, {L{1'b0}}} >> (D_W - 1);
    wire [D_W+R-1:0] mr_w = {aligned, {R{1'b0}}} >> (D_W - 1);
    assign idx = idx_w[L-1:0];
    assign mr = mr_w[R:0];
    generate
        if (PIPE != 0) begin : g_front
            reg [N_W-1:0] an_a, an_b_r, an_c_r;
            reg [D_W-1:0] ad_a, ad_b_r;
            reg [2:0]     fl_a, fl_b_r, fl_c_r;
            reg [PB-1:0]  p_b, p_c_r;
            reg [L-1:0]   idx_c_r;
            reg [R:0]     mr_c_r;
            always @(posedge clk) begin
                {an_a, ad_a, fl_a} <= {an_n, ad_n, neg_n, dz_n, nz_n};
                {an_b_r, ad_b_r, fl_b_r, p_b} <= {an, ad, fl, p_n};
                {an_c_r, fl_c_r, p_c_r, idx_c_r, mr_c_r} <= {an_s, fl_s, p_s, idx, mr};
            end
            // UNIT: no magnitude to take, no magnitude stage (NORM: D registered there)
            if (UNIT != 0 && NORM == 0) begin : g_unit
                assign {an, ad, fl} = {an_n, ad_n, neg_n, dz_n, nz_n};
            end else begin : g_mag
                assign {an, ad, fl} = {an_a, ad_a, fl_a};
            end
            assign {an_b, ad_b, fl_b, p} = {an_b_r, ad_b_r, fl_b_r, p_b};
            assign {an_c, fl_c, p_c, idx_c, mr_c} = {an_c_r, fl_c_r, p_c_r, idx_c_r, mr_c_r};
            if (NORM != 0) begin : g_norm
                // the shift D_W - 1 - p: its bits from SB up, registered, then the rest
                localparam integer SB = (PB > 1) ? PB / 2 : 1;
                reg [D_W-1:0] hi_s;
                reg [SB-1:0]  lo_s;
                reg [N_W-1:0] an_s_r;
                reg [2:0]     fl_s_r;
                reg [PB-1:0]  p_s_r;
                always @(posedge clk) begin
                    hi_s <= ad_b << (((D_W - 1 - p) >> SB) << SB);
                    lo_s <= D_W - 1 - p;
                    {an_s_r, fl_s_r, p_s_r} <= {an_b, fl_b, p};
                end
                assign aligned = hi_s << lo_s;
                assign {an_s, fl_s, p_s} = {an_s_r, fl_s_r, p_s_r};
            end else begin : g_shift
                assign aligned = ad_b << (D_W - 1 - p);
                assign {an_s, fl_s, p_s} = {an_b, fl_b, p};
            end
        end else begin : g_direct
            assign {an, ad, fl} = {an_n, ad_n, neg_n, dz_n, nz_n};
            assign {an_b, ad_b, fl_b, p} = {an, ad, fl, p_n};
            assign aligned = ad_b << (D_W - 1 - p);
            assign {an_s, fl_s, p_s} = {an_b, fl_b, p};
            assign {an_c, fl_c, p_c, idx_c, mr_c} = {an_s, fl_s, p_s, idx, mr};
        end
    endgenerate
    // the ROM read takes two cycles, the address and the data out each registered (the
    // DP16KD's own output register on an ECP5: its clock-to-out, not the array's access
    // time, then starts the path into the first product)
    reg [YW-1:0]  y0_0, y0_1;
    reg [R:0]     mr_0, mr_1;
    reg [N_W-1:0] an_0, an_1;
    reg [PB-1:0]  p_0, p_1;
    reg [2:0]     fl_0;
    reg           neg_1, dz_1, nz_1;
    always @(posedge clk) begin
        y0_0 <= rom[idx_c];
        y0_1 <= y0_0;
        {mr_0, an_0, p_0, fl_0} <= {mr_c, an_c, p_c, fl_c};
        {mr_1, an_1, p_1} <= {mr_0, an_0, p_0};
        {neg_1, dz_1, nz_1} <= fl_0;
    end
    // stages 3-8 (PIPE: products of ML = 3 (PIPE = 2: 4) register stages, fx_pipe.v):
    // t = floor(mR y0 2^-R), e = 2^(R+1) - t; y1 = floor(y0 e 2^-R); |N| y1, its sign, the shift
    localparam integer ML = (PIPE > 1) ? 4 : ((PIPE != 0) ? 3 : 1);
    wire [2*R+1:0] m1;
    fx_umul #(R + 1, YW, PIPE) u_m1 (clk, mr_1, y0_1, m1);
    wire [2*R+1:0] t_full = m1 >> R;
    reg  [EW-1:0]  e_3;
    always @(posedge clk) e_3 <= ({{(EW-1){1'b0}}, 1'b1} << (R + 1)) - t_full[EW-1:0];
    wire [YW-1:0]  y0_3;
    fx_delay #(YW, ML + 1) d_y0 (clk, y0_1, y0_3);
    wire [YW+EW-1:0] m2;
    fx_umul #(YW, EW, PIPE) u_m2 (clk, y0_3, e_3, m2);
    // |N| y1 (UNIT: y1 itself, straight from m2) and the flags beside the products
    wire [PW-1:0]  m3_6;
    wire [PB-1:0]  p_6;
    wire           neg_6, dz_6, nz_6;
    generate
        if (UNIT != 0) begin : g_y1
            wire [PW+YW+EW-1:0] y1_u = m2 >> R;
            assign m3_6 = y1_u[PW-1:0];
            fx_delay #(PB + 3, 2 * ML + 1) d_pf (clk, {p_1, neg_1, dz_1, nz_1},
                                                 {p_6, neg_6, dz_6, nz_6});
        end else begin : g_m3
            reg  [Y1W-1:0] y1_5;
            always @(posedge clk) y1_5 <= m2 >> R;
            wire [N_W-1:0] an_5;
            fx_delay #(N_W, 2 * ML + 2) d_an (clk, an_1, an_5);
            fx_umul #(N_W, Y1W, PIPE) u_m3 (clk, an_5, y1_5, m3_6);
            fx_delay #(PB + 3, 3 * ML + 2) d_pf (clk, {p_1, neg_1, dz_1, nz_1},
                                                 {p_6, neg_6, dz_6, nz_6});
        end
    endgenerate
    reg signed [XW-1:0] x_7;
    reg [SH_W-1:0]  sh_7;
    wire [XW-1:0]   mag = {{(XW-PW){1'b0}}, m3_6} << SHL0;
    wire [XW-1:0]   inf = {{(XW-1){1'b0}}, 1'b1} << (XW - 2);  // beyond any code of S
    always @(posedge clk) begin
        x_7 <= dz_6 ? (nz_6 ? (neg_6 ? -$signed(inf) : $signed(inf)) : {XW{1'b0}})
                    : (neg_6 ? -$signed(mag) : $signed(mag));
        sh_7 <= dz_6 ? {SH_W{1'b0}} : SH0 + SHL0 + p_6;
    end
    // stage 9: the cast (PIPE: its shift registered before the rounding, + 1; PIPE = 2:
    // and its rounded value before the overflow mode, + 1)
    wire [OUT_W-1:0] y_c;
    wire             ovf_c;
    fx_cast_var #(XW, SH_W, SH_MAX, OUT_W, OUT_S, QUANT, OVF, PIPE) u_cast (
        .clk(clk), .x(x_7), .sh(sh_7), .y(y_c), .ovf(ovf_c));
    always @(posedge clk) {y, ovf} <= {y_c, ovf_c};
endmodule

// fx_lead_one: p = the position of the highest one bit of a (0 when a == 0), a balanced
// tree: a at 2^PB leaves, each node the any-one bit and the position of the upper child
// if it has a one bit, else of the lower one (PB levels of a two-way mux, not a chain of W)
module fx_lead_one #(
    parameter integer W = 16,
    parameter integer PB = 4            // 2^PB >= W
) (
    input  wire [W-1:0]  a,
    output wire [PB-1:0] p
);
    localparam integer N = 1 << PB;
    // node i of level l: any one bit v[l*N + i], position q[(l*N + i)*PB +: PB]
    wire [(PB+1)*N-1:0]    v /* verilator split_var */;
    wire [(PB+1)*N*PB-1:0] q /* verilator split_var */;
    wire [N-1:0]           a_n = a;    // zero-extended to the 2^PB leaves
    genvar l, i;
    generate
        for (i = 0; i < N; i = i + 1) begin : g_leaf
            assign v[i] = a_n[i];
            assign q[i*PB +: PB] = {PB{1'b0}};
        end
        for (l = 1; l <= PB; l = l + 1) begin : g_lvl
            localparam [PB-1:0] UP = 1 << (l - 1);
            for (i = 0; i < N; i = i + 1) begin : g_node
                if (i < (N >> l)) begin : g_used
                    localparam integer HI = (l - 1)*N + 2*i + 1;
                    localparam integer LO = (l - 1)*N + 2*i;
                    assign v[l*N + i] = v[HI] | v[LO];
                    assign q[(l*N + i)*PB +: PB] = v[HI] ? (q[HI*PB +: PB] | UP)
                                                         : q[LO*PB +: PB];
                end else begin : g_unused
                    assign v[l*N + i] = 1'b0;
                    assign q[(l*N + i)*PB +: PB] = {PB{1'b0}};
                end
            end
        end
    endgenerate
    assign p = q[PB*N*PB +: PB];
endmodule
