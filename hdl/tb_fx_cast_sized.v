// tb_fx_cast_sized: fx_cast_sized and fx_cast_reg against the generic 64-bit fx_cast on
// every input.
//
// rangefx (tests/test_hdl_range.py): for an IW-bit input (IS: signed) with IF fraction
// bits and the output format (OS, OW, OF), every one of the 2^IW inputs is cast by the
// three modules under all 7 quantisation x 4 overflow modes (fx_cast_reg's result read
// after its clock edge); prints the count of inputs where any sized cast differs from
// the generic one in its code or its overflow flag. Simulation only.
`timescale 1ns / 1ps
module tb_fx_cast_pair #(
    parameter integer IW = 16, parameter integer IS = 1, parameter integer IF = 4,
    parameter integer OW = 8, parameter integer OF = 2, parameter integer OS = 1,
    parameter integer Q = 0, parameter integer O = 0
) (
    input  wire          clk,
    input  wire [IW-1:0] x,
    output wire          bad
);
    localparam integer SW = IS ? IW : IW + 1;
    wire [63:0] x64 = IS ? {{(64-IW){x[IW-1]}}, x} : {{(64-IW){1'b0}}, x};
    wire signed [SW-1:0] xs = IS ? $signed(x) : $signed({1'b0, x});
    wire [OW-1:0] y_generic, y_sized, y_reg;
    wire          o_generic, o_sized, o_reg;
    fx_cast #(IF, OW, OF, OS, Q, O) u_generic (.x(x64), .y(y_generic), .ovf(o_generic));
    fx_cast_sized #(SW, IF, OW, OF, OS, Q, O) u_sized (.x(xs), .y(y_sized), .ovf(o_sized));
    fx_cast_reg #(SW, IF, OW, OF, OS, Q, O) u_reg (.clk(clk), .x(xs), .y(y_reg), .ovf(o_reg));
    assign bad = (y_generic !== y_sized) || (o_generic !== o_sized)
               || (y_generic !== y_reg) || (o_generic !== o_reg);
endmodule

module tb_fx_cast_sized;
    parameter integer IW = 16, IS = 1, IF = 4, OW = 8, OF = 2, OS = 1;
    reg           clk = 1'b0;
    reg  [IW-1:0] x;
    wire [27:0]   bad;
    genvar q, o;
    generate
        for (q = 0; q < 7; q = q + 1) begin : g_q
            for (o = 0; o < 4; o = o + 1) begin : g_o
                tb_fx_cast_pair #(IW, IS, IF, OW, OF, OS, q, o) u (
                    .clk(clk), .x(x), .bad(bad[q * 4 + o]));
            end
        end
    endgenerate
    integer i, n_bad;
    initial begin
        n_bad = 0;
        for (i = 0; i < (1 << IW); i = i + 1) begin
            x = i;
            #1 clk = 1'b1;  // fx_cast_reg's rounded value registered
            #1 clk = 1'b0;
            if (|bad) n_bad = n_bad + 1;
        end
        $display("inputs=%0d mismatching=%0d", 1 << IW, n_bad);
        $finish;
    end
endmodule
