// p1_div_restoring: pipelined radix-2 restoring divider `divide(N, D, S)` of rangefx
// (docs/p1_datapath.md "Dividers", rtl_model/p1/model.py divide_scalar), one division
// per clock, latency Q_W + 4 (rtl_model/runtime.py divider_latency):
//   1 cycle      signs, magnitudes, T = |N| 2^(F_S + 1 + F_D - F_N) (or |D| shifted when
//                that exponent is negative), and the "far out of range" test
//                T >= |D| 2^(Q_W + 2) (also true for D = 0, N != 0);
//   Q_W + 2      one quotient bit per cycle, from 2^(Q_W + 1) (a guard bit below the
//                LSB of S) down to 2^0;
//   1 cycle      sticky bit (remainder != 0), sign, and the cast of
//                sign (2q + sticky) 2^-(F_S + 2) into S, which rounds exactly as S's
//                quantisation mode asks; far out of range feeds 2^(Q_W + 3), which every
//                (saturating) overflow mode clamps as the model's infinite quotient.
// N = 0 gives 0 (also for D = 0, as the model). `ovf` is the final cast's flag.
`timescale 1ns / 1ps
module p1_div_restoring #(
    parameter integer N_W = 40, parameter integer N_F = 21, parameter integer N_S = 1,
    parameter integer D_W = 20, parameter integer D_F = 11, parameter integer D_S = 0,
    parameter integer Q_W = 24, parameter integer Q_F = 12, parameter integer Q_S = 1,
    parameter integer Q_Q = 2,  parameter integer Q_O = 1
) (
    input  wire           clk,
    input  wire [N_W-1:0] n,
    input  wire [D_W-1:0] d,
    output reg  [Q_W-1:0] q,
    output reg            ovf
);
    localparam integer SH  = Q_F + 1 + D_F - N_F;
    localparam integer SHN = (SH > 0) ? SH : 0;
    localparam integer SHD = (SH < 0) ? -SH : 0;
    localparam integer QB  = Q_W + 2;                         // quotient bits
    localparam integer TW  = N_W + SHN;                       // T, unsigned
    localparam integer DDW = D_W + SHD;                       // |D| shifted, unsigned
    localparam integer RW  = ((TW > DDW + QB) ? TW : DDW + QB) + 1;
    localparam integer OW  = Q_W + 5;                         // signed cast input

    // ---- setup ------------------------------------------------------------------------
    wire n_neg = (N_S != 0) && n[N_W-1];
    wire d_neg = (D_S != 0) && d[D_W-1];
    wire [N_W-1:0] an = n_neg ? -n : n;
    wire [D_W-1:0] ad = d_neg ? -d : d;
    wire [RW-1:0] t0 = {{(RW-N_W){1'b0}}, an} << SHN;
    wire [RW-1:0] dd0 = {{(RW-D_W){1'b0}}, ad} << SHD;
    reg  [RW-1:0] rem  [0:QB];
    reg  [RW-1:0] dsh  [0:QB];
    reg  [QB-1:0] qacc [0:QB];
    reg           neg  [0:QB];
    reg           big  [0:QB];
    reg           zero [0:QB];
    always @(posedge clk) begin
        rem[0]  <= t0;
        dsh[0]  <= dd0;
        qacc[0] <= {QB{1'b0}};
        neg[0]  <= n_neg ^ d_neg;
        big[0]  <= t0 >= (dd0 << QB);
        zero[0] <= an == {N_W{1'b0}};
    end

    // ---- one quotient bit per stage ---------------------------------------------------
    genvar k;
    generate
        for (k = 0; k < QB; k = k + 1) begin : g_bit
            wire [RW-1:0] trial = dsh[k] << (QB - 1 - k);
            wire          take = rem[k] >= trial;
            always @(posedge clk) begin
                rem[k+1]  <= take ? rem[k] - trial : rem[k];
                qacc[k+1] <= {qacc[k][QB-2:0], take};
                dsh[k+1]  <= dsh[k];
                neg[k+1]  <= neg[k];
                big[k+1]  <= big[k];
                zero[k+1] <= zero[k];
            end
        end
    endgenerate

    // ---- sign and the final cast ---------------------------------------------------------
    wire [OW-1:0] mag = zero[QB] ? {OW{1'b0}}
                      : big[QB] ? ({{(OW-1){1'b0}}, 1'b1} << (Q_W + 3))
                      : {{(OW-QB-1){1'b0}}, qacc[QB], rem[QB] != {RW{1'b0}}};
    wire [OW-1:0] val = neg[QB] ? -mag : mag;
    wire [Q_W-1:0] y;
    wire           y_ovf;
    fx_cast_sized #(OW, Q_F + 2, 1, Q_W, Q_F, Q_S, Q_Q, Q_O) c_out (
        .x(val), .y(y), .ovf(y_ovf));
    always @(posedge clk) begin
        q <= y;
        ovf <= y_ovf;
    end
endmodule
