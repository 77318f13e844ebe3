// tb_top: a self-contained Verilog bench of p1_top and p2_top (Icarus and Verilator, no
// cocotb: cocotb 2.1 needs Verilator >= 5.036, Debian has 5.006), one protocol for both.
//
// `rangefx hdl replay` generates bench.vh from a vector directory (rangefx.vectors.hdl
// bench_header for P1, p2_bench_header for P2: the top, its parameters, register codes
// and flags, the sizes, and the tap and counter dump statements) and builds this file.
// The bench reads the input streams' `*.stream.mem` words {sof, eol, valid, data}
// ($readmemh; STREAM1 is absent in P1's motion mode), drives one word per clock (cycle k
// of the file in cycle k of the bench), and writes every tap sample while its valid is
// high, every AXI4-Stream output beat, and at the end the overflow counters and the
// flags, as text lines to +OUT=<file>:
//   T <stream|R> <tap> <cycle> <hex value>   G <ovf group> <hex flags>   I <cycle>
//   M <cycle> <hex tdata> <tuser> <tlast>   O <stream|R> <signal> <count>   F <flag> <value>
`timescale 1ns / 1ps
`include "bench.vh"
module tb_top;
    localparam integer PW = `TB_PIX_W + 3;
    localparam integer DEPTH = `TB_STREAM_DEPTH;
    reg clk = 1'b0;
    reg rst = 1'b1;
    reg [PW-1:0] w0 [0:DEPTH-1];
    reg [PW-1:0] w1 [0:DEPTH-1];
    reg [PW-1:0] in0, in1;
    wire [`TB_OUT_W-1:0] m_tdata;
    wire m_tvalid, m_tuser, m_tlast;
    wire [2:0] flag;                 // the top's sticky flags, named in TB_FLAG_PORTS
    `TB_TOP #(`TB_PARAMS) dut (
        .clk(clk), .rst(rst), `TB_REGISTERS,
        .s0_axis_tvalid(in0[PW-3]), .s0_axis_tdata(in0[PW-4:0]), .s0_axis_tuser(in0[PW-1]),
        .s0_axis_tlast(in0[PW-2]),
        .s1_axis_tvalid(in1[PW-3]), .s1_axis_tdata(in1[PW-4:0]), .s1_axis_tuser(in1[PW-1]),
        .s1_axis_tlast(in1[PW-2]),
        .m_axis_tvalid(m_tvalid), .m_axis_tdata(m_tdata), .m_axis_tuser(m_tuser),
        .m_axis_tlast(m_tlast), `TB_FLAG_PORTS);

    integer fd, cycle, k;
    reg [1023:0] path0, path1, out;
    initial begin
        in0 = {PW{1'b0}};
        in1 = {PW{1'b0}};
        for (k = 0; k < DEPTH; k = k + 1) begin
            w0[k] = {PW{1'b0}};
            w1[k] = {PW{1'b0}};
        end
        if (!$value$plusargs("STREAM0=%s", path0) || !$value$plusargs("OUT=%s", out)) begin
            $display("tb_top: need +STREAM0=<file> and +OUT=<file>");
            $finish;
        end
        $readmemh(path0, w0);
        if ($value$plusargs("STREAM1=%s", path1)) $readmemh(path1, w1);
        fd = $fopen(out, "w");
    end
    always #5 clk = ~clk;

    // cycle k lasts from rising edge k to k+1: its input word is driven, and the taps
    // (registers updated at edge k) are sampled, at the falling edge inside it
    initial begin
        cycle = -`TB_LEAD;
        @(negedge clk);
        while (cycle < `TB_CYCLES) begin
            if (cycle == -`TB_LEAD + 3) rst = 1'b0;
            in0 = (cycle >= 0 && cycle < DEPTH) ? w0[cycle] : {PW{1'b0}};
            in1 = (cycle >= 0 && cycle < DEPTH) ? w1[cycle] : {PW{1'b0}};
            if (in0[PW-3]) $fwrite(fd, "I %0d\n", cycle);
            `TB_TAPS
            if (m_tvalid) $fwrite(fd, "M %0d %h %0d %0d\n", cycle, m_tdata, m_tuser, m_tlast);
            @(negedge clk);
            cycle = cycle + 1;
        end
        `TB_COUNTS
        `TB_FLAGS
        $fclose(fd);
        $finish;
    end
endmodule
