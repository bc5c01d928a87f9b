#!/usr/bin/env python3
"""bpm_eval written from the manifest alone (reference_data/vectors/bpm/manifest.json), as an
outside implementer would: the walk-through in src/vectors/README.md. Usage:

    python3 tools/bpm_eval_from_manifest.py reference_data/vectors/bpm out.npy
    reparam verify reference_data/vectors/bpm --candidate out.npy --kernel bpm_eval

Needs numpy. Evaluates in f64; an f32 port passes as well (the bound is per sample).
"""
import json
import sys

import numpy as np


def c(row, k):
    """The complex number stored at columns k, k + 1."""
    return complex(row[k], row[k + 1])


def mobius(m, z):
    """M(z) = (a z + b) / (c z + d) for m = (a, b, c, d)."""
    a, b, cc, d = m
    return (a * z + b) / (cc * z + d)


def eval_sample(row, flags, bj, bk):
    bi = 1.0 - bj - bk
    uv = [c(row, 4), c(row, 6), c(row, 8)]
    if flags & 1:  # the linear fallback
        return bi * uv[0] + bj * uv[1] + bk * uv[2]
    zj, zk = c(row, 0), c(row, 2)  # z_i = 0; already mirrored where flags bit 1 is set
    z = bj * zj + bk * zk
    lengths = [abs(zj), abs(zk - zj), abs(zk)]  # edges ij, jk, ki
    g = [lengths[0] * bi * bj, lengths[1] * bj * bk, lengths[2] * bk * bi]
    total = sum(g)
    gamma = [x / total for x in g] if total != 0 else [0.0, 0.0, 0.0]
    a = b = cc = 0j
    for e in range(3):  # slot e = edge ij, jk, ki
        k = 20 + 8 * e
        a += gamma[e] * c(row, k)
        b += gamma[e] * c(row, k + 2)
        cc += gamma[e] * c(row, k + 4)
    a, b, cc = a / 2, b / 2, cc / 2  # Y = ½ ℓ
    p = a * a + b * cc
    r = np.sqrt(p)
    C = np.cosh(r)
    S = np.sinh(r) / r if r != 0 else 1.0
    e_map = (C + S * a, S * b, S * cc, C - S * a)  # E = exp Y
    m_t = (c(row, 12), c(row, 14), c(row, 16), c(row, 18))
    return c(row, 10) + mobius(m_t, mobius(e_map, z))  # w_origin + M_t(E(z))


def main(directory, out):
    manifest = json.load(open(f"{directory}/manifest.json"))
    kernel = next(k for k in manifest["kernels"] if k["name"] == "bpm_eval")
    inputs = {a["file"].split(".")[-2]: np.load(f"{directory}/{a['file']}") for a in kernel["inputs"]}
    maps, flags, face, bary = (inputs[n] for n in ("maps", "flags", "face", "bary"))
    uv = np.array(
        [
            eval_sample(maps[f].astype(np.float64), int(flags[f]), float(b[0]), float(b[1]))
            for f, b in zip(face, bary)
        ]
    )
    np.save(out, np.stack([uv.real, uv.imag], axis=1))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
