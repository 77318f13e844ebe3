// tb_p2_top: a self-contained Verilog bench of p2_top (Icarus and Verilator, no cocotb).
//
// `rangefx hdl replay` generates p2_bench.vh from a P2 vector directory
// (rangefx.vectors.hdl.p2_bench_header: the design's parameters, register codes, sizes and
// the tap statements) and builds this file. The bench reads the input streams'
// `*.stream.mem` words {sof, eol, valid, data} ($readmemh), drives one word per clock
// (cycle k of the file in cycle k of the bench), and writes every tap sample while its
// register's valid is high, every AXI4-Stream output beat, and at the end the overflow
// counters and the flags, as text lines to +OUT=<file>:
//   T R <tap> <cycle> <hex value>   I <cycle>   M <cycle> <hex tdata> <tuser> <tlast>
//   O R <signal> <count>            F <flag> <value>
`timescale 1ns / 1ps
`include "p2_bench.vh"
module tb_p2_top;
    localparam integer PW = `P2_PIX_W + 3;
    localparam integer DEPTH = `P2_STREAM_DEPTH;
    reg clk = 1'b0;
    reg rst = 1'b1;
    reg [PW-1:0] w0 [0:DEPTH-1];
    reg [PW-1:0] w1 [0:DEPTH-1];
    reg [PW-1:0] in0, in1;
    wire [`P2_OUT_W-1:0] m_tdata;
    wire m_tvalid, m_tuser, m_tlast, align_error, line_too_long, overrun;
    p2_top #(`P2_PARAMS) dut (
        .clk(clk), .rst(rst), `P2_REGISTERS,
        .s0_axis_tvalid(in0[PW-3]), .s0_axis_tdata(in0[PW-4:0]), .s0_axis_tuser(in0[PW-1]),
        .s0_axis_tlast(in0[PW-2]),
        .s1_axis_tvalid(in1[PW-3]), .s1_axis_tdata(in1[PW-4:0]), .s1_axis_tuser(in1[PW-1]),
        .s1_axis_tlast(in1[PW-2]),
        .m_axis_tvalid(m_tvalid), .m_axis_tdata(m_tdata), .m_axis_tuser(m_tuser),
        .m_axis_tlast(m_tlast), .align_error(align_error), .line_too_long(line_too_long),
        .overrun(overrun));

    integer fd, cycle, k;
    reg [1023:0] path0, path1, out;
    initial begin
        in0 = {PW{1'b0}};
        in1 = {PW{1'b0}};
        for (k = 0; k < DEPTH; k = k + 1) begin
            w0[k] = {PW{1'b0}};
            w1[k] = {PW{1'b0}};
        end
        if (!$value$plusargs("STREAM0=%s", path0) || !$value$plusargs("STREAM1=%s", path1)
                || !$value$plusargs("OUT=%s", out)) begin
            $display("tb_p2_top: need +STREAM0=<file> +STREAM1=<file> +OUT=<file>");
            $finish;
        end
        $readmemh(path0, w0);
        $readmemh(path1, w1);
        fd = $fopen(out, "w");
    end
    always #5 clk = ~clk;

    // cycle k lasts from rising edge k to k+1: its input word is driven, and the taps
    // (registers updated at edge k) are sampled, at the falling edge inside it
    initial begin
        cycle = -`P2_LEAD;
        @(negedge clk);
        while (cycle < `P2_CYCLES) begin
            if (cycle == -`P2_LEAD + 3) rst = 1'b0;
            in0 = (cycle >= 0 && cycle < DEPTH) ? w0[cycle] : {PW{1'b0}};
            in1 = (cycle >= 0 && cycle < DEPTH) ? w1[cycle] : {PW{1'b0}};
            if (in0[PW-3]) $fwrite(fd, "I %0d\n", cycle);
            `P2_TAPS
            if (m_tvalid) $fwrite(fd, "M %0d %h %0d %0d\n", cycle, m_tdata, m_tuser, m_tlast);
            @(negedge clk);
            cycle = cycle + 1;
        end
        `P2_COUNTS
        $fwrite(fd, "F line_too_long %0d\nF align_error %0d\nF overrun %0d\n",
                line_too_long, align_error, overrun);
        $fclose(fd);
        $finish;
    end
endmodule
