#!/bin/bash
# tools/compile_log.sh LOG COMMAND...: runs COMMAND with every call of g++, c++, gcc and cc timed,
# one line per call appended to LOG ("user sys wall compiler | arguments"), then prints the total
# compiler CPU time, the calls that took more than 3 s, and how many took less.
# docs/testing.md's inventory of what `make test` compiles comes from it, run in a fresh clone:
#   git clone . /tmp/x && cd /tmp/x && tools/compile_log.sh /tmp/compiles.log make test
# (The CMake build there keeps the logging wrapper as its compiler: remove /tmp/x afterwards.)
set -euo pipefail
if [ $# -lt 2 ]; then
  echo "usage: tools/compile_log.sh LOG COMMAND..." >&2
  exit 2
fi
[ -x /usr/bin/time ] || { echo "tools/compile_log.sh needs /usr/bin/time: apt-get install time" >&2; exit 2; }
log=$(realpath -m "$1")
shift
# The wrappers stay beside the log: a CMake build configured during the run records the c++ it
# found on PATH (the wrapper) as its compiler, so remove that build folder after measuring.
wrappers="$log.wrappers"
mkdir -p "$wrappers"
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
