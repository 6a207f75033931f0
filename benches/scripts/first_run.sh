#!/usr/bin/env bash
# The README's main command on a fresh clone: cold (nothing built), then warm (everything
# built). Prints the wall and CPU times and mbdc's own build line ("built N runtime crate(s)
# and the scene's program in X s": what the compiled path built beyond mbdc itself).
#
#   bash benches/scripts/first_run.sh [COMMIT]      (default: HEAD of this clone)
set -euo pipefail
src="$(cd "$(dirname "$0")/../.." && pwd)"
rev="${1:-HEAD}"
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
git clone -q "$src" "$dir/mbdc"
cd "$dir/mbdc"
git checkout -q "$rev"
echo "commit $(git rev-parse --short HEAD), $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg)"
for pass in cold warm; do
  start=$(date +%s.%N)
  /usr/bin/time -f "%U %S" -o "$dir/cpu" cargo mbdc run models/double_pendulum_3d.mbd > "$dir/$pass.out" 2>&1
  end=$(date +%s.%N)
  read -r user sys < "$dir/cpu"
  printf '%s: %.1f s wall, %.1f s CPU; %s\n' "$pass" "$(echo "$end - $start" | bc)" \
    "$(echo "$user + $sys" | bc)" "$(grep -m1 '^built' "$dir/$pass.out" || echo 'built nothing')"
done
echo "load after: $(cut -d' ' -f1-3 /proc/loadavg)"
