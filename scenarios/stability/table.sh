#!/bin/sh
# Regenerates the README "Stability" table: critical steps (× h/c) per layout at A = 1e-4 and 1e-2.
# Usage: sh scenarios/stability/table.sh   (from the crate root; needs a release build)
set -e
cargo build --release --example critical_dt 2>/dev/null
for f in scenarios/suite/gimp_uniform_ppc1.json scenarios/suite/gimp_uniform_ppc2.json \
         scenarios/suite/gimp_uniform_ppc4.json scenarios/suite/gimp_jittered_ppc1.json \
         scenarios/suite/gimp_jittered_ppc2.json scenarios/suite/gimp_jittered_ppc4.json \
         scenarios/suite/gimp_fixed_ends.json scenarios/stability/gimp_small_mass.json \
         scenarios/suite/linear_uniform.json scenarios/stability/linear_jittered_ppc2.json \
         scenarios/suite/linear_small_mass.json; do
  a=$(./target/release/examples/critical_dt --scenario "$f" --json --amplitude 1e-4 2>/dev/null)
  b=$(./target/release/examples/critical_dt --scenario "$f" --json --amplitude 1e-2 2>/dev/null)
  python3 - "$f" "$a" "$b" <<'PY'
import json, sys, os
f, a, b = sys.argv[1], json.loads(sys.argv[2]), json.loads(sys.argv[3])
r = lambda d: d / a["dt_eq49"]
print(f"| {os.path.basename(f)[:-5]} | {a['shape']} | {a['lambda_max']:.4f} | {a['lambda_max_gershgorin']/a['lambda_max']:.4f} | 1 | {r(a['dt_eq56']):.4f} | {r(a['dt_full_map']):.4f} | {r(a['dt_empirical']):.4f} | {r(b['dt_empirical']):.4f} | {r(a['dt_controller']):.4f} |")
PY
done
