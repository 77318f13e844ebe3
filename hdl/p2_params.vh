// The formats and modes of P2's signals and host registers (p2_top's parameters; each
// signal's <P>_W, _F, _S, _Q, _O; rangefx.vectors.hdl.p2_parameters sets them from a
// config). The last line has no comma.
    parameter integer PIX_W = 16, parameter integer PIX_F = 0, parameter integer PIX_S = 1, parameter integer PIX_Q = 2, parameter integer PIX_O = 1,
    parameter integer D_W = 16, parameter integer D_F = 0, parameter integer D_S = 1, parameter integer D_Q = 2, parameter integer D_O = 1,
    parameter integer G_W = 16, parameter integer G_F = 0, parameter integer G_S = 1, parameter integer G_Q = 2, parameter integer G_O = 1,
    parameter integer KA_W = 16, parameter integer KA_F = 0, parameter integer KA_S = 1, parameter integer KA_Q = 2, parameter integer KA_O = 1,
    parameter integer A_W = 16, parameter integer A_F = 0, parameter integer A_S = 1, parameter integer A_Q = 2, parameter integer A_O = 1,
    parameter integer C_W = 16, parameter integer C_F = 0, parameter integer C_S = 1, parameter integer C_Q = 2, parameter integer C_O = 1,
    parameter integer MR_W = 16, parameter integer MR_F = 0, parameter integer MR_S = 1, parameter integer MR_Q = 2, parameter integer MR_O = 1,
    parameter integer ST_W = 16, parameter integer ST_F = 0, parameter integer ST_S = 1, parameter integer ST_Q = 2, parameter integer ST_O = 1,
    parameter integer DEN_W = 16, parameter integer DEN_F = 0, parameter integer DEN_S = 1, parameter integer DEN_Q = 2, parameter integer DEN_O = 1,
    parameter integer R_W = 16, parameter integer R_F = 0, parameter integer R_S = 1, parameter integer R_Q = 2, parameter integer R_O = 1,
    parameter integer H_W = 16, parameter integer H_F = 0, parameter integer H_S = 1, parameter integer H_Q = 2, parameter integer H_O = 1,
    parameter integer Q_W = 16, parameter integer Q_F = 0, parameter integer Q_S = 1, parameter integer Q_Q = 2, parameter integer Q_O = 1,
    parameter integer W_W = 16, parameter integer W_F = 0, parameter integer W_S = 1, parameter integer W_Q = 2, parameter integer W_O = 1,
    parameter integer LAM_W = 16, parameter integer LAM_F = 0, parameter integer LAM_S = 1, parameter integer LAM_Q = 2, parameter integer LAM_O = 1,
    parameter integer Z_W = 16, parameter integer Z_F = 0, parameter integer Z_S = 1, parameter integer Z_Q = 2, parameter integer Z_O = 1,
    parameter integer E_W = 16, parameter integer E_F = 0, parameter integer E_S = 1, parameter integer E_Q = 2, parameter integer E_O = 1
