// Pipeline building blocks of rangefx P1 (hdl/p1_range.v, p1_frontend.v), timed after
// place and route on an ECP5 (docs/hdl.md):
//   fx_mul18   : an 18 x 18 signed product with its operands and its product registered
//                (latency 2). With RANGEFX_ECP5_DSP defined (the timing flow,
//                tools/studies/timing.py) it is one MULT18X18D with its input and output
//                registers clocked, so neither register is a fabric flip-flop with a long
//                route to the DSP; otherwise a behavioural body of the same latency.
//   fx_mul_pipe: a signed product in FX_MUL_LAT = 3 register stages (IREG = 1: 4), cut
//                where the MULT18X18D tiles end: (IREG = 1: the operand chunks registered
//                in the DSP,) the 18 x 18 partial products (one DSP each, registered),
//                their sums in pairs, the final sum. Operands up to 35 bits give at most
//                4 partial products, so no stage holds more than one carry chain.
//   fx_umul    : an unsigned product, one register or fx_mul_pipe (the dividers;
//                PIPE = 1: 3 stages, PIPE = 2: 4 stages, the DSP's registers).
//   fx_delay   : N registers (N = 0: a wire), for the signals that wait beside a stage;
//                from 8 cycles on a ring buffer in LUT RAM with a registered read.
// Both advance every clock; callers carry their valid bits beside them.
`timescale 1ns / 1ps

// (ports without `signed`: Yosys 0.70's ABC9 fails on the flattened design when a
// MULT18X18D sits in a module with signed ports; the product is signed all the same)
module fx_mul18 (
    input  wire        clk,
    input  wire [17:0] a,
    input  wire [17:0] b,
    output wire [35:0] p
);
`ifdef RANGEFX_ECP5_DSP
    MULT18X18D #(
        .REG_INPUTA_CLK("CLK0"), .REG_INPUTB_CLK("CLK0"), .REG_PIPELINE_CLK("NONE"),
        .REG_OUTPUT_CLK("CLK0"), .GSR("DISABLED"), .RESETMODE("SYNC"),
        .SOURCEB_MODE("B_SHIFT"), .MULT_BYPASS("DISABLED")
    ) u_dsp (
        .A0(a[0]), .A1(a[1]), .A2(a[2]), .A3(a[3]), .A4(a[4]), .A5(a[5]), .A6(a[6]),
        .A7(a[7]), .A8(a[8]), .A9(a[9]), .A10(a[10]), .A11(a[11]), .A12(a[12]),
        .A13(a[13]), .A14(a[14]), .A15(a[15]), .A16(a[16]), .A17(a[17]),
        .B0(b[0]), .B1(b[1]), .B2(b[2]), .B3(b[3]), .B4(b[4]), .B5(b[5]), .B6(b[6]),
        .B7(b[7]), .B8(b[8]), .B9(b[9]), .B10(b[10]), .B11(b[11]), .B12(b[12]),
        .B13(b[13]), .B14(b[14]), .B15(b[15]), .B16(b[16]), .B17(b[17]),
        .SIGNEDA(1'b1), .SIGNEDB(1'b1), .SOURCEA(1'b0), .SOURCEB(1'b0),
        .CLK0(clk), .CE0(1'b1), .RST0(1'b0),
        .P0(p[0]), .P1(p[1]), .P2(p[2]), .P3(p[3]), .P4(p[4]), .P5(p[5]), .P6(p[6]),
        .P7(p[7]), .P8(p[8]), .P9(p[9]), .P10(p[10]), .P11(p[11]), .P12(p[12]),
        .P13(p[13]), .P14(p[14]), .P15(p[15]), .P16(p[16]), .P17(p[17]), .P18(p[18]),
        .P19(p[19]), .P20(p[20]), .P21(p[21]), .P22(p[22]), .P23(p[23]), .P24(p[24]),
        .P25(p[25]), .P26(p[26]), .P27(p[27]), .P28(p[28]), .P29(p[29]), .P30(p[30]),
        .P31(p[31]), .P32(p[32]), .P33(p[33]), .P34(p[34]), .P35(p[35]));
`else
    reg signed [17:0] ar, br;
    reg signed [35:0] pr;
    always @(posedge clk) begin
        {ar, br} <= {a, b};
        pr <= $signed(ar) * $signed(br);
    end
    assign p = pr;
`endif
endmodule

module fx_mul_pipe #(
    parameter integer AW = 18,
    parameter integer BW = 18,
    parameter integer IREG = 0    // 1: operands registered in the DSP (latency 4)
) (
    input  wire                      clk,
    input  wire signed [AW-1:0]      a,
    input  wire signed [BW-1:0]      b,
    output reg  signed [AW+BW-1:0]   y
);
    // chunks: 17-bit unsigned low parts, a signed top part of at most 18 bits
    localparam integer NA = (AW <= 18) ? 1 : (AW - 18 + 16) / 17 + 1;
    localparam integer NB = (BW <= 18) ? 1 : (BW - 18 + 16) / 17 + 1;
    localparam integer NP = NA * NB;
    localparam integer NS = (NP + 1) / 2;
    localparam integer YW = AW + BW;
    localparam integer AX = 17 * NA + 1;  // a and b sign-extended to whole chunks
    localparam integer BX = 17 * NB + 1;
    wire signed [AX-1:0] ax = a;
    wire signed [BX-1:0] bx = b;
    wire [36*NP-1:0] pp;   // stage 1 (IREG: 2): the partial products, registered
    wire [YW*NS-1:0] ps;   // stage 2: their sums in pairs, registered
    genvar i, j, s;
    generate
        for (i = 0; i < NA; i = i + 1) begin : g_a
            wire signed [17:0] ac = (i == NA - 1) ? $signed(ax[17*i +: 18])
                                                 : $signed({1'b0, ax[17*i +: 17]});
            for (j = 0; j < NB; j = j + 1) begin : g_b
                wire signed [17:0] bc = (j == NB - 1) ? $signed(bx[17*j +: 18])
                                                     : $signed({1'b0, bx[17*j +: 17]});
                if (IREG != 0) begin : g_dsp
                    wire signed [35:0] p;
                    fx_mul18 u_m (clk, ac, bc, p);
                    assign pp[36*(i*NB+j) +: 36] = p;
                end else begin : g_fabric
                    reg signed [35:0] p;
                    always @(posedge clk) p <= ac * bc;
                    assign pp[36*(i*NB+j) +: 36] = p;
                end
            end
        end
        for (s = 0; s < NS; s = s + 1) begin : g_pair
            localparam integer K0 = 2 * s;
            localparam integer SH0 = 17 * (K0 / NB + K0 % NB);
            wire signed [YW-1:0] t0 = $signed(pp[36*K0 +: 36]) <<< SH0;
            wire signed [YW-1:0] t1;
            if (K0 + 1 < NP) begin : g_two
                localparam integer SH1 = 17 * ((K0 + 1) / NB + (K0 + 1) % NB);
                assign t1 = $signed(pp[36*(K0+1) +: 36]) <<< SH1;
            end else begin : g_one
                assign t1 = {YW{1'b0}};
            end
            reg signed [YW-1:0] q;
            always @(posedge clk) q <= t0 + t1;
            assign ps[YW*s +: YW] = q;
        end
    endgenerate
    // stage 3: the final sum
    reg signed [YW-1:0] acc;
    integer k;
    always @* begin
        acc = {YW{1'b0}};
        for (k = 0; k < NS; k = k + 1) acc = acc + $signed(ps[YW*k +: YW]);
    end
    always @(posedge clk) y <= acc;
endmodule

// unsigned a * b: PIPE = 0 one register (latency 1), PIPE = 1 fx_mul_pipe (latency 3),
// PIPE = 2 fx_mul_pipe with IREG (latency 4)
module fx_umul #(
    parameter integer AW = 18,
    parameter integer BW = 18,
    parameter integer PIPE = 0
) (
    input  wire              clk,
    input  wire [AW-1:0]     a,
    input  wire [BW-1:0]     b,
    output wire [AW+BW-1:0]  y
);
    generate
        if (PIPE != 0) begin : g_pipe
            wire signed [AW+BW+1:0] p;
            fx_mul_pipe #(AW + 1, BW + 1, (PIPE > 1) ? 1 : 0) u_m (
                clk, $signed({1'b0, a}), $signed({1'b0, b}), p);
            assign y = p[AW+BW-1:0];
        end else begin : g_one
            reg [AW+BW-1:0] p;
            always @(posedge clk) p <= a * b;
            assign y = p;
        end
    endgenerate
endmodule

module fx_delay #(
    parameter integer W = 1,
    parameter integer N = 1
) (
    input  wire         clk,
    input  wire [W-1:0] d,
    output wire [W-1:0] q
);
    // from FX_DELAY_RAM_MIN cycles on, a ring buffer in LUT RAM (ECP5 TRELLIS_DPR16X4)
    // instead of W x N flip-flops: the word written N - 2 clocks earlier is read through
    // two registers (read pointer, data out), so no path holds more than one LUT RAM read
    localparam integer FX_DELAY_RAM_MIN = 8;
    localparam integer AW = (N > 2) ? $clog2(N - 1) : 1;  // 2^AW >= N - 1 words
    generate
        if (N == 0) begin : g_wire
            assign q = d;
        end else if (N < FX_DELAY_RAM_MIN) begin : g_regs
            reg [W*N-1:0] r;
            if (N == 1) begin : g_one
                always @(posedge clk) r <= d;
            end else begin : g_many
                always @(posedge clk) r <= {r[W*(N-1)-1:0], d};
            end
            assign q = r[W*N-1 -: W];
        end else begin : g_ram
            (* ram_style = "distributed" *) reg [W-1:0] mem [0:(1 << AW) - 1];
            // the write pointer leads the read pointer by N - 2: the word written at edge
            // k is read at edge k + N - 2 and leaves its register at edge k + N - 1
            reg [AW-1:0] wp = N - 2;
            reg [AW-1:0] rp = 0;
            reg [W-1:0]  r1, r2;
            always @(posedge clk) begin
                mem[wp] <= d;
                wp <= wp + 1'b1;
                rp <= rp + 1'b1;
                r1 <= mem[rp];
                r2 <= r1;
            end
            assign q = r2;
        end
    endgenerate
endmodule
