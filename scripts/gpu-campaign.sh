#!/usr/bin/env bash
# The GPU campaign (docs/gpu.md): everything a lent GPU machine should measure, in one
# command of at most 9 minutes that writes at most 8 result files.
#
# On the GPU machine (after `bash scripts/gpu-campaign-prepare.sh` here, carrying
# .campaign):   bash scripts/gpu-campaign.sh --out "$OUT"
# Anywhere, at small sizes on whatever adapter is present (lavapipe here; the CUDA peer
# is skipped without cupy), as CI does so the campaign never rots:
#               bash scripts/gpu-campaign.sh --local --small --out DIR
#
# This wrapper unpacks the carried Vulkan loader and libglvnd (the device has NVIDIA's
# ICD but not what it needs to load), picks a Python with numpy, and runs scripts/gpu_campaign.py, which
# holds the steps (adapter, parity, bench, the standard job against the CUDA peer, the
# 1000 x 1000 basin, the GPU tests) and their deadline.
set -uo pipefail
cd "$(dirname "$0")/.."
local_mode=0
for a in "$@"; do [ "$a" = "--local" ] && local_mode=1; done

# The device's image has a libvulkan but not libglvnd, without which NVIDIA's ICD
# (libGLX_nvidia) does not load ("Could not get 'vkCreateInstance'"): unpack both.
if [ "$local_mode" = 0 ] && compgen -G ".campaign/gl/*.deb" >/dev/null; then
  for f in .campaign/gl/*.deb; do dpkg -x "$f" /; done
  ldconfig
fi
# NVIDIA's ICD manifest lives outside the loader's search path on the lent machines.
nv_icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
if [ "$local_mode" = 0 ] && [ -f "$nv_icd" ] && [ -z "${VK_DRIVER_FILES:-}" ]; then
  export VK_DRIVER_FILES=$nv_icd
fi

py=""
for c in python/.venv/bin/python python3 /opt/torch/.venv/bin/python3; do
  if command -v "$c" >/dev/null 2>&1 && "$c" -c "import numpy" 2>/dev/null; then py=$c; break; fi
done
[ -n "$py" ] || { echo "gpu-campaign: no Python with numpy found" >&2; exit 1; }
export PYTHONUNBUFFERED=1
exec "$py" scripts/gpu_campaign.py "$@"
