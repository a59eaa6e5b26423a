#!/usr/bin/env bash
# Runs every command the README's tour and the guide (docs/guide.md) show, so that the
# documentation cannot rot: each line of their ```sh blocks that begins with `jeffcott `
# (continued by a trailing backslash) runs with BIN in place of `jeffcott`, and, given
# PYTHON (an interpreter with the jeffcott package, numpy and matplotlib), each of the
# guide's ```python blocks runs too. All run in one fresh directory that links the
# repository's examples/, in the order the pages give them (later commands read earlier
# outputs, as a reader's would). The set-up commands (`cargo run`, `bash scripts/...`)
# are the test suite's own business and are not run here.
#
#   scripts/docs-commands.sh BIN [PYTHON]
#
# Exit 1 naming the first command that fails.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
bin="$(cd "$(dirname "$1")" && pwd)/$(basename "$1")"
python="${2:-}"
if [ -n "$python" ]; then python="$(cd "$(dirname "$python")" && pwd)/$(basename "$python")"; fi
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
ln -s "$here/examples" "$work/examples"
python3 - "$here" "$work" "$bin" "$python" <<'EOF'
import os, re, subprocess, sys, time
here, work, binary, python = sys.argv[1:5]

def blocks(page, lang):
    """The fenced blocks of `lang` in a page, in order."""
    text = open(os.path.join(here, page)).read()
    return re.findall(r"^```" + lang + r"\n(.*?)^```", text, re.S | re.M)

def commands(block):
    """The `jeffcott ...` commands of a shell block, continuation lines joined and
    trailing comments dropped."""
    out, line = [], ""
    for raw in block.splitlines():
        line += raw.rstrip()
        if line.endswith("\\"):
            line = line[:-1] + " "
            continue
        cmd = re.sub(r"\s+#.*$", "", line).strip()
        if cmd.startswith("jeffcott "):
            out.append(cmd)
        line = ""
    return out

def run(label, argv, shown):
    t0 = time.time()
    r = subprocess.run(argv, cwd=work, capture_output=True, text=True,
                       env=dict(os.environ, MPLBACKEND="Agg"))
    if r.returncode != 0:
        sys.stderr.write(f"docs-commands: FAILED ({label}, exit {r.returncode}): {shown}\n"
                         f"{r.stdout[-3000:]}{r.stderr[-3000:]}")
        sys.exit(1)
    print(f"docs-commands: ok {time.time() - t0:6.1f} s  {label}: {shown}", flush=True)

ran = 0
for page in ["README.md", "docs/guide.md"]:
    for block in blocks(page, "sh"):
        for cmd in commands(block):
            run(page, ["bash", "-c", binary + cmd[len("jeffcott"):]], cmd)
            ran += 1
if python:
    for i, block in enumerate(blocks("docs/guide.md", "python")):
        run("docs/guide.md", [python, "-c", block], f"python block {i + 1}")
        ran += 1
else:
    print("docs-commands: the guide's Python blocks skipped (no PYTHON given)")
if ran == 0:
    sys.exit("docs-commands: found no command to run")
print(f"docs-commands: {ran} commands of the documentation ran")
EOF
