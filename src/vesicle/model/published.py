"""The seed paper's stated values (Zhao & Shaqfeh, J. Fluid Mech. 2011, as SPEC §14 quotes
them): the one place the report, the studies and the figures read them from.

Data only: nothing here is computed, and nothing computed is compared with anything but these.
"""

from __future__ import annotations

__all__ = [
    "PAPER_FIT_AGREEMENT",
    "PAPER_LABEL",
    "PAPER_LAMBDA_C_CHI1",
    "PAPER_PERIOD_EXPONENT",
    "PAPER_SHEAR_THINNING",
    "PAPER_SHEAR_THINNING_CHI",
    "PAPER_TYPE_CHANGE",
    "TABLE1_PAPER",
]

#: SPEC §14, Table 1 of the paper: the most unstable mode (omega_R, omega_I) of the steady TT
#: state at v = 0.95, lam = 8, chi = 10 against the shape degree N (32 x 64 grid).
TABLE1_PAPER = {2: (4.989, 7.336e-2), 4: (3.226, -5.602e-2), 6: (2.967, -7.542e-2),
                8: (2.939, -8.064e-2), 10: (2.937, -8.254e-2), 12: (2.937, -8.295e-2),
                14: (2.937, -8.310e-2)}  # fmt: skip

#: How the figures and tables name the paper's stated values (the column of the paper's
#: values, and the label of what is drawn on the figures).
PAPER_LABEL = "paper (SPEC §14)"
#: SPEC §14: lambda_c at v = 0.95, chi = 1.
PAPER_LAMBDA_C_CHI1 = 8.46
#: The neutral curve's change of bifurcation type (chi) by reduced volume: near 0.25 at v = 0.95
#: (SPEC §14) and near 0.6 at v = 0.90 (the paper's Figure 7, as
#: docs/notes/continuation-measurements.md cites it).
PAPER_TYPE_CHANGE = {0.95: 0.25, 0.90: 0.6}
#: SPEC §14: near lambda_c at low shear the tumbling period grows like (lam - lam_c)^(-1/2).
PAPER_PERIOD_EXPONENT = 0.5
#: The paper's Figure 16 (as issue 41 quotes it; SPEC §14: "weakly shear-thinning"): S_xz falls
#: by "about 10 %" from chi = 0.2 to chi = 10 for each lam it shows (1, 2, 4, 8.7).
PAPER_SHEAR_THINNING = 0.10
#: The chi range of that reduction.
PAPER_SHEAR_THINNING_CHI = (0.2, 10.0)
#: SPEC §14: the fit of the relaxing psi(t) agrees with the stability analysis "to about 1 %".
PAPER_FIT_AGREEMENT = 0.01
