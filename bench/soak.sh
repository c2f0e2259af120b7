#!/usr/bin/env bash
# Soak run (issue 31): for MINUTES minutes, mix builds, saves, loads, queries of every kind
# (closest and any hit as streams, LOD renders of block files), renders, kills at random
# moments of builds, full disks and corrupted files, and check after each step what must
# hold: the command succeeded, or failed cleanly (exit status 1-2 with a message, no signal,
# no hang); answers of lossless representations equal a reference BVH's bit for bit; a
# killed or failed build left the previous file byte for byte; the next build removed what
# the killed one left. Prints each step and a summary; exit status 1 if anything failed.
#   bench/soak.sh MINUTES [PACKRT]   (PACKRT default build/packrt; work dir $SOAK_DIR or a temp dir)
set -u
minutes=${1:?usage: bench/soak.sh MINUTES [PACKRT]}
P=$(realpath "${2:-build/packrt}")
W=${SOAK_DIR:-$(mktemp -d /tmp/packrt-soak.XXXXXX)}
mkdir -p "$W" && cd "$W" || exit 1
end=$(( $(date +%s) + minutes * 60 ))
RANDOM=${SOAK_SEED:-$$}
declare -A done_n=() fail_n=()
failures=()
step=0

note() { printf '%5d %-10s %s\n' "$step" "$1" "$2"; }
ok() { done_n[$1]=$(( ${done_n[$1]:-0} + 1 )); }
bad() { fail_n[$1]=$(( ${fail_n[$1]:-0} + 1 )); failures+=("step $step $1: $2"); note "$1" "FAILED: $2"; }
# A clean failure: exit status 1 or 2 (not a signal, not a timeout) and a message.
clean_fail() { local rc=$1 err=$2; [ "$rc" -ge 1 ] && [ "$rc" -le 2 ] && [ -s "$err" ]; }
leftovers() { ls -a | grep -E "^$1\.tmp\." || true; }

specs_lossless=(aabb:float3 quad:float3-soa4 wide8:idx32-soa4 skd:float3-soa8 aabb-split:idx8-soa4 raystrips cgrid)
specs_lossy=(quad:bitpack-soa4 wide8:strip-bitpack aabb:idx8-bitpack-soa4 lossygrid)
kinds=(sphere:20k mandelbulb:60k terrain:30k torus:20k cad:20k)

# Rays: from a sphere of radius 4 towards points in [-1, 1]^3 (the generators' scale).
/usr/bin/python3 - <<'PY' || python3 - <<'PY'
import random, struct
random.seed(1)
with open("q.rays", "wb") as f:
    n = 20000
    f.write(b"PRTRAYS1" + struct.pack("<Q", n))
    for _ in range(n):
        while True:
            o = [random.uniform(-1, 1) for _ in range(3)]
            r2 = sum(x * x for x in o)
            if 0.01 < r2 <= 1: break
        o = [4 * x / r2 ** 0.5 for x in o]
        t = [random.uniform(-1, 1) for _ in range(3)]
        f.write(struct.pack("<8f", *o, 0.0, *[t[k] - o[k] for k in range(3)], float("inf")))
PY
import random, struct
PY

pick() { local -n a=$1; echo "${a[RANDOM % ${#a[@]}]}"; }
# Same triangles hit, t within 1e-5 relative: raystrips and cgrid use other triangle tests
# than the BVHs (Pluecker edges, Wald's projection), which differ in the last bits of t;
# the BVH codecs must agree bit for bit (cmp).
near_hits() {
  /usr/bin/python3 - "$1" "$2" <<'PY'
import struct, sys
a, b = (open(f, "rb").read() for f in sys.argv[1:3])
if len(a) != len(b) or a[:16] != b[:16]: sys.exit(1)
for i in range(16, len(a), 16):
    ta, pa = struct.unpack_from("<fI", a, i); tb, pb = struct.unpack_from("<fI", b, i)
    if pa != pb or (pa != 0xFFFFFFFF and abs(ta - tb) > 1e-5 * abs(tb)): sys.exit(1)
PY
}
T() { timeout 300 "$@"; }

while [ "$(date +%s)" -lt "$end" ]; do
  step=$((step + 1))
  case $((RANDOM % 7)) in
  0) # build + save + load + stream queries against the reference
    k=$(pick kinds); s=$(pick specs_lossless)
    T "$P" build --gen "$k" -r aabb:float3 -o ref.prt 2>err || { bad build "reference $k: $(tail -1 err)"; continue; }
    T "$P" build --gen "$k" -r "$s" -o a.prt 2>err || { bad build "$k $s: $(tail -1 err)"; continue; }
    T "$P" cast ref.prt --rays q.rays -o ref.hits 2>err && T "$P" cast a.prt --rays q.rays -o a.hits 2>>err &&
      T "$P" cast ref.prt --rays q.rays -o ref.occ --occluded 2>>err && T "$P" cast a.prt --rays q.rays -o a.occ --occluded 2>>err ||
      { bad query "$k $s: $(tail -1 err)"; continue; }
    same=cmp; case $s in raystrips|cgrid) same=near_hits ;; esac
    if $same ref.hits a.hits && cmp -s ref.occ a.occ; then ok query; note query "$k $s: 20000 closest and any hits agree with the reference ($same)"
    else bad query "$k $s: hits differ from aabb:float3"; fi
    [ -z "$(leftovers a.prt)$(leftovers ref.prt)" ] || bad build "temporaries left: $(leftovers a.prt)" ;;
  1) # lossy representations and out-of-core files: build, info, cast, LOD render
    k=$(pick kinds)
    if [ $((RANDOM % 2)) = 0 ]; then s=$(pick specs_lossy); out=l.prt; else s=ooc; out=o.ooc; fi
    T "$P" build --gen "$k" -r "$s" -o $out 2>err || { bad build "$k $s: $(tail -1 err)"; continue; }
    T "$P" info $out >/dev/null 2>err && T "$P" cast $out --rays q.rays -o l.hits 2>>err || { bad load "$k $s: $(tail -1 err)"; continue; }
    lod=""; [ $s = ooc ] && lod="--lod 2 --cache 4M --frames 20"
    T "$P" render $out -o l.png --size 160x120 --shade shadows $lod 2>err >/dev/null || { bad render "$k $s: $(tail -1 err)"; continue; }
    ok build; note build "$k $s: built, loaded, cast, rendered" ;;
  2) # a build killed with SIGKILL at a random moment: the previous file stays whole
    k=mandelbulb:$(( (RANDOM % 6 + 2) * 100 ))k; s=$( [ $((RANDOM % 2)) = 0 ] && echo ooc || echo quad:float3-soa4 )
    out=kill.$([ $s = ooc ] && echo ooc || echo prt)
    [ -f $out ] || T "$P" build --gen mandelbulb:50k -r $s -o $out 2>err >/dev/null || { bad kill "first build: $(tail -1 err)"; continue; }
    cp $out prev.bin
    delay=$(( RANDOM % 3000 ))
    "$P" build --gen "$k" -r "$s" -o $out >/dev/null 2>&1 & pid=$!
    sleep "$(printf '%d.%03d' $((delay / 1000)) $((delay % 1000)))"; kill -9 $pid 2>/dev/null; wait $pid 2>/dev/null; rc=$?
    # Killed after its rename (while loading the file back for its report), a build has put
    # the whole new file in place: it must load and hold the requested mesh.
    renamed=""
    if [ $rc = 137 ] && ! cmp -s $out prev.bin; then
      tris=$(T "$P" info $out 2>/dev/null | awk '/^triangles/ {print $2}')
      if [ -n "$tris" ] && [ "$tris" -gt 100000 ]; then renamed=" (after its rename: the complete new file, $tris triangles)"
      else bad kill "$k $s killed after ${delay} ms: the previous file changed and the new one does not load"; continue; fi
    fi
    T "$P" build --gen mandelbulb:50k -r $s -o $out 2>err >/dev/null || { bad kill "rebuild: $(tail -1 err)"; continue; }
    [ -z "$(leftovers $out)" ] || { bad kill "temporaries after the rebuild: $(leftovers $out)"; continue; }
    ok kill; note kill "$k $s $([ $rc = 137 ] && echo "killed after ${delay} ms" || echo "finished before the kill")${renamed:-: previous file intact}, rebuild clean" ;;
  3) # a corrupted or truncated file: a clean error, never a crash or a hang
    src=$(ls a.prt l.prt o.ooc kill.ooc kill.prt 2>/dev/null | shuf -n 1); [ -n "$src" ] || continue
    size=$(stat -c %s "$src"); cp "$src" c.bin
    case $((RANDOM % 3)) in
      0) how="truncated to $((size * (RANDOM % 100) / 100)) bytes"; truncate -s $((size * (RANDOM % 100) / 100)) c.bin ;;
      1) off=$(( (RANDOM * 32768 + RANDOM) % size )); how="byte $off flipped"
         printf "\\x$(printf %02x $(( ($(od -An -tu1 -j$off -N1 c.bin) ^ 0xff) )))" | dd of=c.bin bs=1 seek=$off conv=notrunc 2>/dev/null ;;
      2) off=$(( (RANDOM * 32768 + RANDOM) % size )); how="64 random bytes at $off"
         head -c 64 /dev/urandom | dd of=c.bin bs=1 seek=$off conv=notrunc 2>/dev/null ;;
    esac
    T "$P" info c.bin >/dev/null 2>err; rc=$?
    if [ $rc = 0 ]; then T "$P" cast c.bin --rays q.rays -o c.hits 2>err >/dev/null; rc=$?; fi
    if [ $rc -ge 3 ] && [ $rc != 0 ]; then bad corrupt "$src $how: exit status $rc ($(tail -1 err))"; continue; fi
    ok corrupt; note corrupt "$src $how: $([ $rc = 0 ] && echo "still loads (bytes the checks do not cover)" || echo "clean error: $(tail -1 err | cut -c1-90)")" ;;
  4) # a full disk (a 64 KB file size limit): a clean error naming the file, the previous file whole
    s=$( [ $((RANDOM % 2)) = 0 ] && echo ooc || echo wide8:float3 ); out=full.$([ $s = ooc ] && echo ooc || echo prt)
    [ -f $out ] || T "$P" build --gen sphere:2k -r $s -o $out 2>err >/dev/null || { bad full "first build: $(tail -1 err)"; continue; }
    cp $out prev.bin
    (ulimit -f 64; trap '' XFSZ; exec timeout 300 "$P" build --gen mandelbulb:100k -r $s -o $out) >/dev/null 2>err; rc=$?
    if clean_fail $rc err && grep -q "$out" err && cmp -s $out prev.bin && [ -z "$(leftovers $out)" ]; then ok full; note full "$s: $(tail -1 err | cut -c1-90)"
    else bad full "$s: status $rc, $(tail -1 err), previous $(cmp -s $out prev.bin && echo intact || echo CHANGED), left: $(leftovers $out)"; fi ;;
  5) # renders of every shading mode
    m=$(pick kinds); sh=$(echo normal diffuse shadows ao gi | tr ' ' '\n' | shuf -n 1)
    T "$P" gen "${m%%:*}" --tris "${m##*:}" -o r.ply 2>err >/dev/null && T "$P" render r.ply -o r.png --size 128x96 --shade $sh --spp 2 2>err >/dev/null &&
      T "$P" render r.ply -o r.ppm --size 128x96 --shade $sh --spp 2 --threads 1 2>>err >/dev/null ||
      { bad render "$m $sh: $(tail -1 err)"; continue; }
    ok render; note render "$m $sh: png and ppm" ;;
  6) # a killed generator streaming a mesh: the previous mesh stays whole
    [ -f g.ply ] || T "$P" gen sphere --tris 10k -o g.ply 2>/dev/null >/dev/null
    cp g.ply prev.bin; delay=$(( RANDOM % 2000 ))
    "$P" gen mandelbulb --tris 2M -o g.ply >/dev/null 2>&1 & pid=$!
    sleep "$(printf '%d.%03d' $((delay / 1000)) $((delay % 1000)))"; kill -9 $pid 2>/dev/null; wait $pid 2>/dev/null; rc=$?
    if [ $rc = 137 ] && ! cmp -s g.ply prev.bin && ! T "$P" info g.ply 2>/dev/null | grep -q 'triangles *[0-9]\{7\}'; then
      bad kill "gen killed after $delay ms: the previous mesh changed and the new one is not whole"; continue; fi
    T "$P" gen sphere --tris 10k -o g.ply 2>err >/dev/null || { bad kill "regenerate: $(tail -1 err)"; continue; }
    [ -z "$(leftovers g.ply)" ] || { bad kill "temporaries after regenerating: $(leftovers g.ply)"; continue; }
    ok kill; note kill "gen mandelbulb $([ $rc = 137 ] && echo "killed after $delay ms" || echo finished): previous mesh intact" ;;
  esac
done

echo
echo "soak: $step steps in $minutes minutes ($W)"
for k in $(printf '%s\n' "${!done_n[@]}" "${!fail_n[@]}" | sort -u); do
  printf '  %-8s %5d passed %5d failed\n' "$k" "${done_n[$k]:-0}" "${fail_n[$k]:-0}"
done
if [ ${#failures[@]} -gt 0 ]; then printf '  %s\n' "${failures[@]}"; exit 1; fi
echo "soak: nothing failed"
