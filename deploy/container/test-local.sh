#!/usr/bin/env bash
# The container recipe built and run on this machine, where no image registry can be reached:
#   1. a base image made from Debian's packages (debootstrap --variant=minbase), imported into podman;
#   2. deploy/container/Containerfile built on it, its `build` stage replaced by the sweep binary
#      built here (`--build-context build=DIR`: no Rust toolchain image can be fetched here); with
#      SWEEP_CONTAINER_FULL=1, the whole recipe, its cargo build too, on a Rust image made here;
#   3. the image run: a coordinator and a worker in two containers, a plan shipped in the image
#      submitted from a third and finished; local mode (`sweep run`) in a container writing its
#      database and Figure 2 to a volume, as uid 65532.
# Needs root. Installs podman, runc and debootstrap from Debian when missing.
# Usage: deploy/container/test-local.sh [path/to/sweep]   (default: target/release/sweep)
set -euo pipefail
repo=$(cd "$(dirname "$0")/../.." && pwd)
sweep=${1:-$repo/target/release/sweep}
[[ -x $sweep ]] || { echo "no sweep binary at $sweep" >&2; exit 2; }
started=$(date +%s)
say() { echo "[container-test +$(($(date +%s) - started)) s] $*"; }
if ! command -v podman >/dev/null || ! command -v runc >/dev/null || ! command -v debootstrap >/dev/null; then
    DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends podman runc debootstrap >/dev/null
fi

work=$(mktemp -d /tmp/sweep-container.XXXXXX)
cleanup() {
    podman rm -f sweep-test-coordinator sweep-test-worker >/dev/null 2>&1 || true
    rm -rf "$work"
}
trap cleanup EXIT
export CONTAINERS_CONF=${CONTAINERS_CONF:-$repo/deploy/container/podman-here.conf}

# 1. The base image, once per machine. debootstrapped NAME [PACKAGES] [podman import --change ...]
debootstrapped() {
    local name=$1 include=$2; shift 2
    podman image exists "$name" && return 0
    say "debootstrap --variant=minbase ${include:+--include=$include }bookworm for $name"
    debootstrap --variant=minbase ${include:+--include="$include"} bookworm "$work/rootfs" >"$work/debootstrap.log" 2>&1 || {
        tail "$work/debootstrap.log"; exit 1; }
    rm -rf "$work"/rootfs/var/cache/apt/archives/*.deb "$work"/rootfs/var/lib/apt/lists/* \
        "$work"/rootfs/usr/share/{doc,man,info,locale}/*
    if [[ -n ${toolchain:-} ]]; then mkdir -p "$work/rootfs/usr/local/rust" && cp -a "$toolchain"/{bin,lib,libexec} "$work/rootfs/usr/local/rust/"; fi
    tar -C "$work/rootfs" -c . | podman import -q "$@" - "$name" >/dev/null
    rm -rf "$work/rootfs"
}
base=localhost/sweep-test/debian:bookworm-minbase
debootstrapped "$base" ""

# 2. The image: the recipe's runtime stage over the binary built here, stripped as the recipe strips
# it; or, with SWEEP_CONTAINER_FULL=1, the whole recipe, its cargo build too (about 16 min on 2
# cores), on a Rust image made here: Debian's gcc and libc6-dev, and this machine's toolchain
# (`rustc --print sysroot`), with this machine's cargo registry mounted so that crates come from it.
if [[ ${SWEEP_CONTAINER_FULL:-0} == 1 ]]; then
    toolchain=$(rustc --print sysroot)
    rust=localhost/sweep-test/rust:$(rustc --version | cut -d' ' -f2)
    debootstrapped "$rust" gcc,libc6-dev,ca-certificates \
        --change "ENV PATH=/usr/local/rust/bin:/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin" \
        --change "ENV CARGO_HOME=/usr/local/cargo"
    say "building the whole recipe on $rust"
    registry=${CARGO_HOME:-$HOME/.cargo}/registry mount=()
    if [[ -d $registry ]]; then mount=(-v "$registry:/usr/local/cargo/registry"); fi
    podman build -q --network=host "${mount[@]}" \
        -f "$repo/deploy/container/Containerfile" --build-arg RUST_IMAGE="$rust" --build-arg RUNTIME_IMAGE="$base" \
        -t localhost/sweep:test "$repo" >/dev/null
else
    mkdir -p "$work/stage/out/bin" "$work/stage/out/data"
    strip -o "$work/stage/out/bin/sweep" "$sweep"
    podman build -q -f "$repo/deploy/container/Containerfile" --build-arg RUNTIME_IMAGE="$base" \
        --build-context build="$work/stage" -t localhost/sweep:test "$repo" >/dev/null
fi
say "built localhost/sweep:test: $(podman image inspect localhost/sweep:test --format '{{.Size}}' | awk '{printf "%.0f MB", $1 / 1e6}') (base $(podman image inspect "$base" --format '{{.Size}}' | awk '{printf "%.0f MB", $1 / 1e6}'))"
[[ $(podman run --rm --network=none localhost/sweep:test --version) == "sweep "* ]]
[[ $(podman run --rm --network=none --entrypoint id localhost/sweep:test -u) == 65532 ]]

# 3a. A coordinator and a worker in containers, the plan submitted from a third.
install -d -o 65532 -g 65532 "$work/data" "$work/secret"
head -c 32 /dev/urandom | base64 >"$work/secret/token"
chown 65532:65532 "$work/secret/token" && chmod 400 "$work/secret/token"
run() { podman run --network=host -v "$work/secret:/etc/sweep:ro" "$@"; }
run -d --name sweep-test-coordinator -v "$work/data:/var/lib/sweep" localhost/sweep:test \
    coordinator --listen 127.0.0.1:0 --db /var/lib/sweep/campaign.db --token-file /etc/sweep/token >/dev/null
for _ in $(seq 100); do podman logs sweep-test-coordinator 2>/dev/null | grep -q '^listening on' && break; sleep 0.1; done
url=http://$(podman logs sweep-test-coordinator 2>/dev/null | sed -n 's/^listening on //p')
run -d --name sweep-test-worker localhost/sweep:test \
    worker --coordinator "$url" --token-file /etc/sweep/token --core-count 1 >/dev/null
client() { run --rm localhost/sweep:test "$@" --coordinator "$url" --token-file /etc/sweep/token; }
client submit /usr/share/sweep/plans/noop.toml >/dev/null 2>&1
for _ in $(seq 300); do
    status=$(client status --format json)
    grep -q '"done": 1000' <<<"$status" && break
    sleep 1
done
grep -q '"done": 1000' <<<"$status" || { echo "not done: $status"; podman logs sweep-test-worker; exit 1; }
podman stop -t 30 sweep-test-worker sweep-test-coordinator >/dev/null
[[ $(podman inspect sweep-test-worker --format '{{.State.ExitCode}}') == 0 ]] || { echo "the worker did not stop cleanly on SIGTERM"; exit 1; }
say "ok: coordinator and worker containers finished the image's noop plan (1000 points); the worker stopped cleanly on SIGTERM"

# 3b. Local mode in a container: the image's smoke plan, its database and Figure 2 on the volume.
podman run --rm --network=none -v "$work/data:/var/lib/sweep" localhost/sweep:test run /usr/share/sweep/plans/smoke.toml --db local.db >/dev/null 2>&1
podman run --rm --network=none -v "$work/data:/var/lib/sweep" localhost/sweep:test report fig2 --db local.db --out fig2.svg >/dev/null 2>&1
grep -q '<svg' "$work/data/fig2.svg"
[[ $(stat -c %u "$work/data/local.db") == 65532 ]]
say "ok: sweep run in a container: $("$sweep" query "SELECT count(*) FROM jobs WHERE state = 'done'" --db "$work/data/local.db" --format csv | tail -1) points done, fig2.svg written as uid 65532"
say "passed in $(($(date +%s) - started)) s"
