#!/usr/bin/env bash
# densemap-map and densemap-replay on hostile files: each must exit 1 with an error naming the
# file, never crash (exit >= 128) and never map the file (exit 0).
#   bad_files_cli.sh BUILD_DIR
set -uo pipefail
build="$(cd "$1" && pwd)"
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
cd "$dir"
python3 - <<'PY'
import struct, os
def hdr(fields, size, typ, count, n, data='binary', vp='0 0 0 1 0 0 0'):
    return (f"VERSION 0.7\nFIELDS {fields}\nSIZE {size}\nTYPE {typ}\nCOUNT {count}\nWIDTH {n}\nHEIGHT 1\n"
            f"VIEWPOINT {vp}\nPOINTS {n}\nDATA {data}\n").encode()
files = {
    'empty.pcd': b'',
    'count_minus_one.pcd': hdr('x y z', '4 4 4', 'F F F', '-1 1 1', 1) + struct.pack('3f', 1, 2, 3),
    'type_u.pcd': hdr('x y z', '4 4 4', 'U U U', '1 1 1', 1) + struct.pack('3I', 1, 2, 3),
    'size_3.pcd': hdr('x y z', '3 3 3', 'F F F', '1 1 1', 1) + b'\0' * 9,
    'cut_header.pcd': hdr('x y z', '4 4 4', 'F F F', '1 1 1', 1)[:40],
    'viewpoint_nan.pcd': hdr('x y z', '4 4 4', 'F F F', '1 1 1', 1, vp='nan 0 0 1 0 0 0') + struct.pack('3f', 1, 2, 3),
    'ascii_garbage.pcd': hdr('x y z', '4 4 4', 'F F F', '1 1 1', 3, data='ascii') + b'1 2 3\nhello world foo\n4 5 6\n',
    'claims_2e28_points.pcd': hdr('x y z', '4 4 4', 'F F F', '1 1 1', 2**28),
}
for name, data in files.items():
    open(name, 'wb').write(data)
os.makedirs('seq/clouds'); os.makedirs('seq/poses')
for i in (0, 1):
    open(f'seq/clouds/{i}.pcd', 'wb').write(hdr('x y z', '4 4 4', 'F F F', '1 1 1', 1) + struct.pack('3f', 1, 2, 3) if i == 0 else b'')
    open(f'seq/poses/{i}.txt', 'w').write('1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n')
PY
failed=0
check() {  # PROGRAM NAME ARGS...
  local program="$1" name="$2"; shift 2
  local out rc
  out="$("$build/$program" "$@" 2>&1)"; rc=$?
  if [ "$rc" -ne 1 ] || ! grep -q "$name" <<< "$out"; then
    echo "FAIL: $(basename "$program") $* exited $rc; expected 1 with an error naming $name:"; echo "$out" | tail -3
    failed=1
  else
    echo "ok: $(basename "$program") on $name: $(grep -m1 -i error <<< "$out" | sed 's/^\[[^]]*\] //')"
  fi
}
for f in *.pcd; do
  check tools/densemap-map "$f" --source "$f"
  check client/densemap-replay "$f" --source "$f" --domain 163 --wait 1
done
check tools/densemap-map "1.pcd" --source seq
check client/densemap-replay "1.pcd" --source seq --domain 163 --wait 1
exit $failed
