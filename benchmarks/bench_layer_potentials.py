"""Layer potentials N and K: matrix-free vs assembled, per shape and per apply, vs DGEMM."""

from __future__ import annotations

import time

import numpy as np

import vesicle as vs
from vesicle.stokes import LayerPotentials, singular_quadrature

from common import best_time, dgemm_rate


def _pull_back_rate(n: int, transform: str = "gemm") -> tuple[float, float]:
    """Time per ring and FLOP rate of the adjoint rotate-and-synthesise kernel (assembly's BLAS
    core), counting the matrix products it does: the phi' DFT product (``"gemm"``; the FFT
    path's transform is not counted), Legendre over l >= m, Wigner over m' <= l."""
    q = singular_quadrature(n)
    K, b = q.grid.n_phi, 12
    v = np.random.default_rng(0).standard_normal((q.n_nodes, b, K))
    t = best_time(lambda: q.pull_back_unphased(n // 2, v, transform), repeat=3)
    L1 = q.lmax + 1
    B = b * K
    # the products actually done (l >= m, m' <= l), real and imaginary parts each:
    # Legendre sum_m (L1 - m) x n_rot x B, Wigner sum_l (l + 1)^2 x B
    legendre = 2.0 * (L1 * (L1 + 1) / 2) * q.n_rot * B
    wigner = 2.0 * sum((l + 1) ** 2 for l in range(L1)) * B
    dft = 2.0 * (2 * L1) * q.n_rot_phi * q.n_rot * B if transform == "gemm" else 0.0
    flops = 2 * (legendre + wigner) + dft
    return t, flops / t


def _matrix_free(shape, f) -> dict:
    mf = LayerPotentials(shape, method="matrix-free")

    def geometry():
        mf.__dict__.pop("rings", None)
        return mf.rings

    row = {"mf_geometry_s": best_time(geometry, repeat=2)}
    row["mf_apply_N_s"] = best_time(lambda: mf.single_layer(f), repeat=2)
    row["mf_apply_K_s"] = best_time(lambda: mf.double_layer(f), repeat=2)
    arrays = [(g.xh, g.weight, g.normal_weighted, g.inv_r) for g in mf.rings]
    row["mf_memory_MB"] = sum(a.nbytes for group in arrays for a in group) / 1e6
    return row


def _assembled(shape, f) -> dict:
    def assemble():
        lp = LayerPotentials(shape, method="assembled")
        _ = lp.single_matrix
        return lp

    row = {"asm_build_s": best_time(assemble, repeat=2)}

    def assemble_reference():
        lp = LayerPotentials(shape, method="assembled", backend="numpy")
        _ = lp.single_matrix

    row["asm_build_numpy_s"] = best_time(assemble_reference, repeat=2)
    asm = assemble()
    row["asm_apply_N_s"] = best_time(lambda: asm.single_layer(f), number=5)
    row["asm_apply_K_s"] = best_time(lambda: asm.double_layer(f), number=5)
    row["asm_memory_MB"] = (asm.single_matrix.nbytes + asm.double_matrix[0].nbytes) / 1e6
    return row


def _report(n: int, row: dict, gemm: float) -> None:
    print(f"  {n}x{2 * n}: Wigner tables {row['tables_once_per_grid_s']:.2f} s (once per grid)")
    print(
        f"    matrix-free: geometry {row['mf_geometry_s']:.3f} s/shape, apply N "
        f"{row['mf_apply_N_s']:.3f} s, K {row['mf_apply_K_s']:.3f} s, "
        f"{row['mf_memory_MB']:.0f} MB"
    )
    print(
        f"    assembled:   build {row['asm_build_s']:.3f} s/shape (N and K), apply N "
        f"{row['asm_apply_N_s'] * 1e3:.1f} ms, K {row['asm_apply_K_s'] * 1e3:.1f} ms, "
        f"{row['asm_memory_MB']:.0f} MB"
    )
    print(
        f"    build with the NumPy reference kernel: {row['asm_build_numpy_s']:.3f} s "
        f"(fused Numba kernel {row['asm_build_numpy_s'] / row['asm_build_s']:.2f}x faster)"
    )
    for applies in (2, 30):
        a, m = row[f"per_apply_{applies}_asm_s"], row[f"per_apply_{applies}_mf_s"]
        best = "assembled" if a < m else "matrix-free"
        print(
            f"    {applies:2d} applies/shape: per apply assembled {a:.3f} s, "
            f"matrix-free {m:.3f} s -> {best}"
        )
    print(
        f"    adjoint rotate-and-synthesise kernel: {row['pull_back_ring_s'] * 1e3:.1f} ms/ring, "
        f"{row['pull_back_fraction_of_dgemm'] * gemm / 1e9:.1f} GFLOP/s = "
        f"{row['pull_back_fraction_of_dgemm']:.0%} of one-thread DGEMM"
    )


def run() -> dict:
    gemm = dgemm_rate()
    print(f"  DGEMM rate (1 thread): {gemm / 1e9:.1f} GFLOP/s")
    results = {"dgemm_flops": gemm}
    for n in (32, 48):
        shape = vs.Shape.spheroid(0.9, grid=n, degree=8).perturbed(0.02, seed=1)
        f = np.random.default_rng(1).standard_normal((3, n, 2 * n))
        t0 = time.perf_counter()
        _ = singular_quadrature(n).wigner
        row = {"tables_once_per_grid_s": time.perf_counter() - t0}
        row.update(_matrix_free(shape, f))
        row.update(_assembled(shape, f))
        for applies in (2, 30):
            half = applies / 2
            mf = row["mf_geometry_s"] + half * (row["mf_apply_N_s"] + row["mf_apply_K_s"])
            asm = row["asm_build_s"] + half * (row["asm_apply_N_s"] + row["asm_apply_K_s"])
            row[f"per_apply_{applies}_mf_s"] = mf / applies
            row[f"per_apply_{applies}_asm_s"] = asm / applies
        t_pb, rate = _pull_back_rate(n)
        t_ref, rate_ref = _pull_back_rate(n, "fft")
        row["pull_back_ring_s"] = t_pb
        row["pull_back_fraction_of_dgemm"] = rate / gemm
        row["pull_back_fft_ring_s"] = t_ref
        row["pull_back_fft_fraction_of_dgemm"] = rate_ref / gemm
        print(f"  {n}x{2 * n} pull-back per ring: DFT product {1e3 * t_pb:.1f} ms "
              f"({100 * rate / gemm:.0f} % of DGEMM), FFT reference {1e3 * t_ref:.1f} ms "
              f"({100 * rate_ref / gemm:.0f} % counting its products only): "
              f"{t_ref / t_pb:.2f}x")  # fmt: skip
        results[f"{n}x{2 * n}"] = row
        _report(n, row, gemm)
    return results
