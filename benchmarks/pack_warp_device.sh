#!/bin/bash
# Pack Warp and warp_mpm for a lent GPU machine (the `device` tool), in three parts that three calls carry to one warm
# machine (round 42; ../shared/device/pack.sh packs Taichi only: Warp's warp.so is 299 MB, 77 MB under `xz -9`, and a
# call carries at most 64 MiB with the working tree's ~31 MB).
#
#   bash benchmarks/pack_warp_device.sh            # here: writes .wp1/ .wp2/ .wp3/ (ignored by git); xz -9 takes minutes
#   then, in the device tool, each call within the machine's 30 s idle release of the one before:
#     run command="mkdir -p /tmp/w && cp .wp1/part_* /tmp/w/"  carry=[".wp1"]
#     run command="mkdir -p /tmp/w && cp .wp2/part_* /tmp/w/"  carry=[".wp2"]
#     run command="bash .wp3/setup_warp.sh && PYTHONPATH=/tmp/site python3 benchmarks/gpu_contact.py --engine warp_mpm \
#                  --device cuda --out \$OUT"  carry=[".wp3"]
#
# What travels: warp.so (xz -9, split), Warp's Python files without its tests and examples, wheels of the core, of
# warp_mpm and of the pure-Python packages the device's image lacks. warp-clang.so (Warp's CPU compiler) stays here:
# on the device Warp runs CUDA only.
set -eu
root=$(git rev-parse --show-toplevel); cd "$root"
site=$(python3 -c "import warp, os; print(os.path.dirname(os.path.dirname(warp.__file__)))")
ver=$(python3 -c "import importlib.metadata as m; print(m.version('warp-lang'))")
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
for d in .wp1 .wp2 .wp3; do rm -rf "$d"; mkdir -p "$d"; grep -qx "/$d/" .git/info/exclude || echo "/$d/" >> .git/info/exclude; done
xz -9 -T2 -c "$site/warp/bin/warp.so" > "$tmp/warp.so.xz"
(cd "$tmp" && split -b 33000000 -a 2 warp.so.xz part_)
mv "$tmp/part_aa" .wp1/; mv "$tmp/part_ab" .wp2/; mv "$tmp"/part_a[c-z] .wp3/
(cd "$site" && tar --exclude='warp/bin' --exclude='warp/tests' --exclude='warp/examples' --exclude='__pycache__' \
    -cf - warp "warp_lang-$ver.dist-info") | xz -6 > .wp3/warp_py.tar.xz
mkdir -p .wp3/whl
python3 -m pip download -q --no-deps --only-binary=:all: -d .wp3/whl dill plyfile trimesh tomli-w
python3 -m pip wheel -q --no-deps -w .wp3/whl . plugins/warp_mpm
cat > .wp3/setup_warp.sh <<'SH'
#!/bin/bash
# On the device: the wheels, Warp's Python files and warp.so (its parts copied into /tmp/w by the earlier calls)
# into /tmp/site.
set -e
h=$(cd "$(dirname "$0")" && pwd)
mkdir -p /tmp/site /tmp/w
cp "$h"/part_* /tmp/w/ 2>/dev/null || true
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site "$h"/whl/*.whl
tar -xJf "$h/warp_py.tar.xz" -C /tmp/site
mkdir -p /tmp/site/warp/bin
cat /tmp/w/part_* | xz -d > /tmp/site/warp/bin/warp.so
PYTHONPATH=/tmp/site python3 -c "import warp as wp; wp.init(); print('warp', wp.config.version, wp.get_cuda_devices())"
SH
chmod +x .wp3/setup_warp.sh
du -sh .wp1 .wp2 .wp3
echo "each call carries its part beside the working tree: $(git ls-files -z | xargs -0 du -cb 2>/dev/null | tail -1 | cut -f1) bytes tracked"
