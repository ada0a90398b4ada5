#!/usr/bin/env python3
"""Writes the comparison suite of scenario files (issue 6). Seeded: re-running reproduces the
committed files byte for byte. Not needed to build or test the crate."""
import json, math, random

def per_cell(k):
    return {"per_cell": k}

def jittered(cells, k, seed, length=1.0, amount=0.5):
    rng = random.Random(seed)
    h = length / cells
    l = h / k
    xs = []
    for c in range(cells):
        for j in range(k):
            xs.append(c * h + (j + 0.5) * l + rng.uniform(-amount, amount) * 0.5 * l)
    return {"positions": [round(x, 12) for x in xs]}

def small_mass_linear(cells, k, targets, squeeze=0.004, length=1.0):
    """Uniform k per cell, except that around each target node the particles of the two
    adjacent cells sit near the far ends, so the node's linear-hat mass is ~1% of typical."""
    h = length / cells
    xs = []
    for c in range(cells):
        for j in range(k):
            x = c * h + (j + 0.5) * h / k
            for t in targets:
                if c == t - 1:
                    x = c * h + (squeeze + j * squeeze) * h
                elif c == t:
                    x = (c + 1) * h - (squeeze + j * squeeze) * h
            xs.append(x)
    return {"positions": [round(x, 12) for x in sorted(xs)]}

def scenario(name, cells=64, shape="gimp", boundary="periodic", E=1.0, rho=1.0,
             material="linear_elastic", particles=None, amplitude=1e-2, mode=1, periods=2.0,
             note=""):
    c = math.sqrt(E / rho)
    period = 1.0 / (mode * c)  # v = A c sin(2πkx/L) cos(2πkct/L) on both boundaries
    s = {
        "cells": cells, "length": 1.0, "boundary": boundary,
        "youngs_modulus": E, "density": rho, "shape": shape, "material": material,
        "particles": particles or per_cell(2),
        "initial": {"standing_wave": {"amplitude": amplitude, "mode": mode}},
        "t_end": round(periods * period, 12),
    }
    with open(f"{name}.json", "w") as f:
        json.dump(s, f, indent=1)
        f.write("\n")

for k in (1, 2, 4):
    scenario(f"gimp_uniform_ppc{k}", particles=per_cell(k))
    scenario(f"gimp_jittered_ppc{k}", particles=jittered(64, k, seed=100 + k))
scenario("gimp_large_amplitude", amplitude=0.25, particles=per_cell(2))
scenario("linear_small_mass", shape="linear", particles=small_mass_linear(64, 2, [16, 40]))
scenario("linear_uniform", shape="linear", particles=per_cell(2))
scenario("gimp_fixed_ends", boundary="fixed", particles=per_cell(2))
scenario("neo_hookean_large_strain", material="neo_hookean", amplitude=0.3, particles=per_cell(2))
for E in (1e-2, 1.0, 1e4):
    tag = {1e-2: "1e-2", 1.0: "1e0", 1e4: "1e4"}[E]
    scenario(f"gimp_E{tag}", E=E, particles=per_cell(2))
