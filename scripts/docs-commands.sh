#!/usr/bin/env bash
# Runs every command the README's tour and the guide (docs/guide.md) show, so that the
# documentation cannot rot: each line of their ```sh blocks that begins with `jeffcott `
# (continued by a trailing backslash) runs with BIN in place of `jeffcott`, and, given
# PYTHON (an interpreter with the jeffcott package, numpy and matplotlib), each of the
# guide's ```python blocks runs too. All run in one fresh directory that links the
# repository's examples/, in the order the pages give them (later commands read earlier
# outputs, as a reader's would). A `jeffcott explore` line starts the server without a
# browser, fetches its page and /api/info, and stops it. The set-up commands (`cargo run`, `bash scripts/...`)
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

def serve(label, argv, shown):
    """A server command (`jeffcott explore`): started without a browser on a free port,
    its page and its /api/info fetched, then stopped."""
    import urllib.request
    t0 = time.time()
    argv = argv + ["--no-browser", "--port", "0"]
    p = subprocess.Popen(argv, cwd=work, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = p.stdout.readline()
        m = re.search(r"(http://\S+)", line)
        if not m:
            raise RuntimeError(f"no address printed: {line!r} {p.stderr.read() if p.poll() is not None else ''}")
        url = m.group(1)
        page = urllib.request.urlopen(url, timeout=30).read().decode()
        info = urllib.request.urlopen(url.rstrip("/") + "/api/info", timeout=30).read().decode()
        if "app.js" not in page or '"params"' not in info:
            raise RuntimeError("the page or /api/info is not what the explorer serves")
    except Exception as e:
        sys.stderr.write(f"docs-commands: FAILED ({label}): {shown}: {e}\n")
        sys.exit(1)
    finally:
        p.terminate()
        p.wait(timeout=10)
    print(f"docs-commands: ok {time.time() - t0:6.1f} s  {label}: {shown} (served, page fetched)", flush=True)

ran = 0
for page in ["README.md", "docs/guide.md"]:
    for block in blocks(page, "sh"):
        for cmd in commands(block):
            if cmd.startswith("jeffcott explore"):
                serve(page, [binary] + cmd.split()[1:], cmd)
            else:
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
