#!/bin/bash
# tools/compile_log.sh LOG COMMAND...: runs COMMAND with every call of g++, c++, gcc and cc timed,
# one line per call appended to LOG ("user sys wall compiler | arguments"), then prints the total
# compiler CPU time, the calls that took more than 3 s, and how many took less.
# docs/testing.md's inventory of what `make test` compiles comes from it, e.g.
#   IPGEN_CACHE_DIR=$(mktemp -d) tools/compile_log.sh /tmp/compiles.log \
#     .venv/bin/python -m pytest -q -n 2 -m "not fresh_venv"
set -euo pipefail
if [ $# -lt 2 ]; then
  echo "usage: tools/compile_log.sh LOG COMMAND..." >&2
  exit 2
fi
[ -x /usr/bin/time ] || { echo "tools/compile_log.sh needs /usr/bin/time: apt-get install time" >&2; exit 2; }
log=$(realpath -m "$1")
shift
wrappers=$(mktemp -d)
trap 'rm -rf "$wrappers"' EXIT
for compiler in g++ c++ gcc cc; do
  real=$(command -v "$compiler" || true)
  [ -n "$real" ] || continue
  cat > "$wrappers/$compiler" <<EOF
#!/bin/bash
exec /usr/bin/time -a -o "$log" -f "%U %S %e $compiler | \$*" "$real" "\$@"
EOF
  chmod +x "$wrappers/$compiler"
done
: > "$log"
status=0
PATH="$wrappers:$PATH" "$@" || status=$?
awk -F' [|] ' '{split($1, t, " "); cpu = t[1] + t[2]; total += cpu
  if (cpu > 3) { printf "%6.1f s  %s\n", cpu, substr($2, 1, 160); big += cpu; n++ } else small++ }
  END { printf "%d compiler calls, %.0f s of compiler CPU time: %d over 3 s (%.0f s), %d under\n", NR, total, n, big, small }' "$log"
exit "$status"
