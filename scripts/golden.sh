#!/usr/bin/env bash
# The refactoring check: runs a fixed set of commands (reproduce --smoke, every study
# once, a sharded basin and its merge, every Python function and the Python example) and
# writes a manifest of what they produced, one line per file with its SHA-256. A
# refactor proves itself when the manifests before and after are identical.
#
#   scripts/golden.sh run BIN OUT [PYTHON]   run the set with binary BIN into OUT and
#                                            write OUT/MANIFEST (PYTHON: an interpreter
#                                            with the jeffcott wheel installed; without
#                                            it the Python part is left out and the
#                                            manifest says so)
#   scripts/golden.sh compare A B            compare two manifests (or their folders);
#                                            exit 1 and list the files that differ
#   scripts/golden.sh selftest BIN [PYTHON]  run the set twice with BIN and compare: the
#                                            set runs and its manifest is deterministic
#                                            (the README's test command runs this, so
#                                            the script cannot rot)
#
# What varies from run to run is masked before hashing, and nothing else: in JSON files
# the keys that hold wall times, dates, versions, hosts and adapters, in Markdown the
# durations ("12.3 s") and the cells of table columns headed "wall [s]", and in both the output folder's and the binary's paths. Everything else, PNGs and .npy included, is hashed as it is.
#
# Typical use, before and after a refactor (about 2 minutes on 2 cores):
#   cp target/release/jeffcott /tmp/jeffcott-before      # built at the old commit
#   scripts/golden.sh run /tmp/jeffcott-before /tmp/g-before python/.venv/bin/python
#   cargo build --release && (build and install the wheel)
#   scripts/golden.sh run target/release/jeffcott /tmp/g-after python/.venv/bin/python
#   scripts/golden.sh compare /tmp/g-before /tmp/g-after
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"

manifest() {
  python3 - "$1" "$2" <<'EOF'
import hashlib, json, os, re, sys
root, binary = sys.argv[1], sys.argv[2]
absroot = os.path.abspath(root)
# Keys whose values change from run to run of the same command.
VOLATILE = {"wall_time_s", "seconds", "elapsed_s", "started", "finished", "created",
            "version", "jeffcott_version", "jeffcott_commit", "host", "hostname", "pid", "device", "adapter", "adapters",
            "driver", "threads", "backend_info", "time_s", "command_time_s"}
def scrub(v):
    if isinstance(v, dict):
        return {k: ("<masked>" if k in VOLATILE or k.endswith(("_time_s", "_seconds", "_per_s")) else scrub(x)) for k, x in v.items()}
    if isinstance(v, list):
        return [scrub(x) for x in v]
    return v
def mask_wall_columns(data):
    # Table columns headed "wall [s]" (e.g. the spectra's wall time per speed).
    out, col = [], None
    for line in data.split(b"\n"):
        cells = line.split(b"|")
        if not line.startswith(b"|"):
            col = None
        elif col is None:
            names = [c.strip() for c in cells]
            col = names.index(b"wall [s]") if b"wall [s]" in names else None
        elif len(cells) > col and not set(cells[col].strip()) <= set(b"-:"):
            cells[col] = b" <t> "
            line = b"|".join(cells)
        out.append(line)
    return b"\n".join(out)
lines = []
for d, _, files in os.walk(root):
    for f in files:
        p = os.path.join(d, f)
        rel = os.path.relpath(p, root)
        if rel in ("MANIFEST",) or f == ".jeffcott.lock" or rel.startswith("logs/"):
            continue
        data = open(p, "rb").read()
        if f.endswith((".json", ".md")):
            # The folders and the binary the set ran with are named in the records.
            data = data.replace(absroot.encode(), b"<out>").replace(binary.encode(), b"<bin>")
        if f.endswith(".json"):
            try:
                data = json.dumps(scrub(json.loads(data)), sort_keys=True).encode()
            except ValueError:
                pass
        elif f.endswith(".md"):
            data = re.sub(rb"\d+(\.\d+)? ?(s|min|ms)\b", b"<t>", data)
            data = mask_wall_columns(data)
        lines.append(f"{hashlib.sha256(data).hexdigest()}  {rel}")
open(os.path.join(root, "MANIFEST"), "w").write("\n".join(sorted(lines, key=lambda l: l[66:])) + "\n")
print(f"golden.sh: {len(lines)} files in {root}/MANIFEST")
EOF
}

run_set() {
  local bin out py
  bin="$(realpath "$1")"
  out="$(realpath -m "$2")"
  py="${3:-}"
  rm -rf "$out"
  mkdir -p "$out/logs"
  local j=("--backend" "cpu" "--quiet")
  step() {
    local name="$1"
    shift
    echo "golden.sh: $name"
    "$@" >"$out/logs/$name.log" 2>&1 || {
      echo "golden.sh: $name failed:"
      cat "$out/logs/$name.log"
      exit 1
    }
  }
  step reproduce "$bin" reproduce --smoke "${j[@]}" --out "$out/reproduce"
  step simulate "$bin" simulate --omega 132.2 --transient 60 --periods 24 --spectrum-periods 24 --csv --quiet --out "$out/simulate"
  step simulate-article "$bin" simulate --omega 135 --transient 20 --periods 8 --integrator article --spectrum-periods 12 --quiet --out "$out/simulate-article"
  step ensemble "$bin" ensemble --omega 130:141:12 --transient 40 --periods 8 --lyapunov "${j[@]}" --out "$out/ensemble"
  step bifurcation "$bin" bifurcation --omega 131:135:6 --ics 2 --transient 20 --transient-first 40 --brute-transient 40 --periods 12 --portraits 133 "${j[@]}" --out "$out/bifurcation"
  step bifurcation-sweeps "$bin" bifurcation --omega 131:135:6 --ics 0 --transient 20 --transient-first 40 --periods 12 --portraits 131,133 "${j[@]}" --out "$out/bifurcation-sweeps"
  step basin "$bin" basin --omega 133 --x x_r:-0.006:0.006:10 --y vx_r:-1:1:9 --transient 120 --periods 16 --refine 1 --uncertainty-samples 6 --highlight-boundary "${j[@]}" --out "$out/basin"
  step basin-lyapunov "$bin" basin --omega 137.25 --x x_r:-0.004:0.004:6 --y vx_r:-0.5:0.5:5 --fix y_r=0.0005 --transient 80 --periods 16 --lyapunov --param mu=0.12 "${j[@]}" --out "$out/basin-lyapunov"
  local shards=()
  for i in 0 1 2; do
    step "basin-shard$i" "$bin" basin --omega 133 --x x_r:-0.006:0.006:8 --y vx_r:-1:1:7 --transient 100 --periods 16 --chunk 9 --shard "$i/3" "${j[@]}" --out "$out/shards/s$i"
    shards+=("$out/shards/s$i")
  done
  step merge "$bin" merge --quiet --out "$out/merged" "${shards[@]}"
  rm -rf "$out/shards"
  step map "$bin" map --x omega:131:137:4 --y e:2e-5:6e-5:3 --ics 2 --transient 60 --periods 12 "${j[@]}" --out "$out/map"
  step continuation "$bin" continuation --vary omega:132:134:3 --ics 6 --transient 60 --periods 12 "${j[@]}" --out "$out/continuation"
  step cascade "$bin" cascade --omega 130:140:4 --transient-first 40 --transient 20 --periods 24 --csv --quiet --out "$out/cascade"
  step basin-stability "$bin" basin-stability --omega 132:134:2 --sample 12 --box x_r:-0.004:0.004,vx_r:-0.5:0.5 --transient 60 --periods 12 "${j[@]}" --out "$out/basin-stability"
  step orbits "$bin" orbits --vary omega:131.7:132.4 --follow-doublings --coord vx_s --over "$out/bifurcation" --quiet --out "$out/orbits"
  step orbits-from "$bin" orbits --vary omega:131:131.5 --from "$out/bifurcation" --no-plot --quiet --out "$out/orbits-from"
  step lyapunov "$bin" lyapunov --omega 135 --transient 40 --time 3 --min-time 3 --quiet --out "$out/lyapunov"
  step lyapunov-range "$bin" lyapunov --omega 131:135:6 --transient 40 --time 2 --min-time 2 --quiet --out "$out/lyapunov-range"
  if [ -n "$py" ]; then
    step python "$py" "$here/golden_python.py" "$out/python"
    step python-example env MPLBACKEND=Agg "$py" "$here/../python/examples/article_figures.py" --quick --out "$out/python-example"
  else
    echo "python part left out (no interpreter given)" >"$out/PYTHON-SKIPPED"
  fi
  manifest "$out" "$bin"
}

case "${1:-}" in
  run)
    [ $# -ge 3 ] || { echo "usage: $0 run BIN OUT [PYTHON]" >&2; exit 2; }
    run_set "$2" "$3" "${4:-}"
    ;;
  manifest)
    # (Re)writes OUT/MANIFEST of a finished set run with BIN.
    [ $# -eq 3 ] || { echo "usage: $0 manifest OUT BIN" >&2; exit 2; }
    manifest "$(realpath -m "$2")" "$(realpath "$3")"
    ;;
  compare)
    [ $# -eq 3 ] || { echo "usage: $0 compare A B" >&2; exit 2; }
    a="$2"; b="$3"
    [ -d "$a" ] && a="$a/MANIFEST"
    [ -d "$b" ] && b="$b/MANIFEST"
    if diff <(cat "$a") <(cat "$b") >/dev/null; then
      echo "golden.sh: identical ($(wc -l <"$a") files)"
    else
      echo "golden.sh: these files differ or exist on one side only:"
      join -j 2 -a 1 -a 2 -e MISSING -o 0,1.1,2.1 <(sort -k2 "$a") <(sort -k2 "$b") |
        awk '$2 != $3 {print "  " $1}'
      exit 1
    fi
    ;;
  selftest)
    [ $# -ge 2 ] || { echo "usage: $0 selftest BIN [PYTHON]" >&2; exit 2; }
    tmp=$(mktemp -d)
    trap 'rm -rf "$tmp"' EXIT
    run_set "$2" "$tmp/a" "${3:-}" >/dev/null
    run_set "$2" "$tmp/b" "${3:-}" >/dev/null
    # The two runs' folders differ by name: compare the manifests' hashes and paths.
    "$0" compare "$tmp/a/MANIFEST" "$tmp/b/MANIFEST"
    ;;
  *)
    sed -n '2,28p' "$0" >&2
    exit 2
    ;;
esac
