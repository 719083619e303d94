#!/usr/bin/env bash
# Whether the working tree computes the same bits as revision REV (default
# HEAD) on ten short 2D runs (single field, both partitions, finite strain
# with damage, contact, APIC, CPDI): both are built with -ffp-contract=off, so
# that a refactor that keeps every operation in its order gives identical
# files whatever the compiler inlines (with contraction on, the fused
# multiply-adds it forms depend on inlining: docs/performance/determinism.md).
#   bash tools/same_bits.sh [REV]
# Builds in /tmp/same_bits, or $PFMPM_TOOLS_ROOT/same_bits where two sessions
# share /tmp (a few minutes per side); prints an md5 per file
# and side, and exits 1 when a file differs.
set -euo pipefail
cd "$(dirname "$0")/.."
rev=${1:-HEAD}
root=${PFMPM_TOOLS_ROOT:-/tmp}/same_bits
source tools/two_trees.sh

runs=(
  "borden_sf demos/borden_plate.toml --set grid.h=1.0 --set materials.concrete.fracture.l0=2.0 --set bodies.plate.particles_per_cell=2"
  "borden_dfg demos/borden_plate.toml --set grid.h=1.0 --set materials.concrete.fracture.l0=2.0 --set bodies.plate.particles_per_cell=2 --set contact.partition=damage_gradient"
  "charpy demos/charpy.toml --set time.end=40 --set output.every=200"
  "disk_beam demos/disk_beam.toml --set time.end=10"
  "wedge_disk_block demos/wedge_disk_block.toml --set time.end=40"
  "brazilian demos/brazilian.toml --set time.end=5"
  "vibrating_bar demos/vibrating_bar.toml --set time.end=10"
  "borden_apic demos/borden_plate.toml --set grid.h=1.0 --set materials.concrete.fracture.l0=2.0 --set bodies.plate.particles_per_cell=2 --set transfer.scheme=apic"
  "bar_cpdi demos/vibrating_bar.toml --set time.end=10 --set grid.degree=1 --set grid.shape=cpdi"
  "disk_beam_cpdi demos/disk_beam.toml --set time.end=5 --set grid.degree=1 --set grid.shape=cpdi"
)
for side in old new; do
  (cd "$root/$side" && CMAKE_ARGS="-DCMAKE_CXX_FLAGS=-ffp-contract=off" bash tools/setup.sh > "$root/$side.log" 2>&1)
  for run in "${runs[@]}"; do
    read -r name args <<< "$run"
    # shellcheck disable=SC2086
    (cd "$root/$side" && OMP_NUM_THREADS=1 .venv/bin/pfmpm run $args --set output.particles=false \
      --out "$root/out/$side/$name" --quiet > /dev/null 2>> "$root/$side.log")
  done
done
status=0
for run in "${runs[@]}"; do
  read -r name _ <<< "$run"
  old=$(md5sum < "$root/out/old/$name/energies.csv" | cut -c1-32)
  new=$(md5sum < "$root/out/new/$name/energies.csv" | cut -c1-32)
  verdict="same"
  [ "$old" = "$new" ] || { verdict="DIFFERENT"; status=1; }
  printf '%-18s %s %s %s\n' "$name" "$old" "$new" "$verdict"
done
exit $status
