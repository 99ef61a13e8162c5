"""Layout of the O(n) operator's factorisation workspace (see
:mod:`cable_sim.integrate.implicit.operator`): the rows of ``W`` (n per-link values), the entries
of ``S`` (scalars), the end modes, and 1/12.

Integrate layer: no imports.
"""

#: 1/12 (a multiply per link instead of a division: equal to round-off).
_TWELFTH = 1.0 / 12.0

# rows of the per-link workspace W (n columns; _W_D holds 1/D_i); _W_CA, _W_CB: the link's
# seabed contact interval; _W_PX, _W_PZ: scratch of the product (per-link forces of the Morison
# and contact terms)
(_W_COS, _W_SIN, _W_D, _W_UX, _W_UZ, _W_BETA, _W_ROT, _W_GT, _W_GE, _W_BCN, _W_DROT, _W_KGEO,
 _W_CA, _W_CB, _W_PX, _W_PZ) = range(16)
# rows of the solve's factors, formed once per factorisation (see
# op_factor._solve_factors): g = u/D (x, z), k = beta/D, k l t (x, z) and the affine map's
# entries 1 - g_x l t_x, g_x l t_z, g_z l t_x, 1 - g_z l t_z
(_W_GX, _W_GZ, _W_K, _W_KX, _W_KZ, _W_AXX, _W_AXZ, _W_AZX, _W_AZZ) = range(16, 25)
_NW = 25
# entries of the scalar workspace S
_S_BETA0, _S_AZZ, _S_J00, _S_J01, _S_J10, _S_J11, _S_MODE, _S_MC = range(8)
_NS = 8
_MODE_NONE, _MODE_CONSTRAINED, _MODE_HEAVY = 0.0, 1.0, 2.0
