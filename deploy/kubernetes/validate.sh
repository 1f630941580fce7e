#!/usr/bin/env bash
# Offline checks of the Kubernetes manifests, no cluster needed:
#   1. renders them with `kubectl kustomize`, with throw-away secret files (a token and a
#      self-signed CA + coordinator certificate made here with openssl);
#   2. validates every rendered object against the API schemas with `kubernetes-validate --strict`
#      (PyPI; installed with pip when missing) for the Kubernetes versions below;
#   3. checks that every flag the containers pass is one the sweep binary accepts;
#   4. with SWEEP_K8S_IMAGE=IMAGE (root, podman; deploy/container/test-local.sh builds
#      localhost/sweep:test), runs the two pods as a kubelet would, in podman (pods_for_podman.py):
#      the rendered args with $(CPU_LIMIT) from the CPU limit, the Secrets as files with their
#      modes and the pod's fsGroup, the volume, the user, a read-only root, the Service's name, in a
#      network namespace of their own; the workers' CPU patched down to 1 to fit a small machine.
#      It submits a plan over TLS, waits for it, and stops the worker, which must exit cleanly.
# Usage: [SWEEP_K8S_IMAGE=IMAGE] deploy/kubernetes/validate.sh [path/to/sweep]   (default: target/release/sweep)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
sweep=${1:-$here/../../target/release/sweep}
versions=(1.30.0 1.37.0)
command -v kubectl >/dev/null || { echo "needs kubectl (for kustomize)" >&2; exit 2; }
command -v kubernetes-validate >/dev/null || pip install -q kubernetes-validate

work=$(mktemp -d)
cleanup() {
    if [[ -n ${SWEEP_K8S_IMAGE:-} ]]; then # the worker first: it is in the coordinator's network
        podman rm -f sweep-k8s-worker >/dev/null 2>&1 || true
        podman rm -f sweep-k8s-coordinator >/dev/null 2>&1 || true
    fi
    rm -rf "$work"
}
trap cleanup EXIT
cp "$here"/*.yaml "$work/"
head -c 32 /dev/urandom | base64 >"$work/token"
openssl req -x509 -newkey rsa:2048 -nodes -days 1 -subj /CN=sweep-test-ca \
    -keyout "$work/ca.key" -out "$work/ca.crt" 2>/dev/null
openssl req -newkey rsa:2048 -nodes -subj /CN=sweep-coordinator -keyout "$work/tls.key" -out "$work/tls.csr" 2>/dev/null
openssl x509 -req -in "$work/tls.csr" -CA "$work/ca.crt" -CAkey "$work/ca.key" -CAcreateserial -days 1 \
    -extfile <(printf 'subjectAltName=DNS:sweep-coordinator,DNS:localhost') -out "$work/tls.crt" 2>/dev/null

kubectl kustomize "$work" >"$work/rendered.yaml"
echo "rendered: $(grep -c '^kind:' "$work/rendered.yaml") objects ($(grep '^kind:' "$work/rendered.yaml" | sort | uniq -c | awk '{printf "%s %s, ", $1, $3}' | sed 's/, $//'))"
for version in "${versions[@]}"; do
    kubernetes-validate --strict -k "$version" "$work/rendered.yaml"
done

# 3. The containers' flags against the binary's own --help.
python3 - "$work/rendered.yaml" "$sweep" <<'EOF'
import re, subprocess, sys, yaml
rendered, sweep = sys.argv[1], sys.argv[2]
bad = 0
for doc in yaml.safe_load_all(open(rendered)):
    spec = (doc or {}).get("spec", {}).get("template", {}).get("spec", {})
    for container in spec.get("containers", []):
        command, *args = container["args"]
        accepted = set(re.findall(r"--[a-z][a-z-]*", subprocess.run([sweep, command, "--help"], capture_output=True, text=True, check=True).stdout))
        for flag in (a.split("=")[0] for a in args if a.startswith("--")):
            ok = flag in accepted
            bad += not ok
            print(f"{doc['metadata']['name']}: sweep {command} {flag}: {'ok' if ok else 'UNKNOWN FLAG'}")
sys.exit(1 if bad else 0)
EOF
echo "the Kubernetes manifests are valid"
[[ -n ${SWEEP_K8S_IMAGE:-} ]] || exit 0
export CONTAINERS_CONF=${CONTAINERS_CONF:-$here/../container/podman-here.conf}

# 4. The pods in podman. The workers' CPU (4 in workers.yaml) patched down to this machine.
cat >>"$work/kustomization.yaml" <<'EOF'
patches:
  - target: {kind: Deployment, name: sweep-worker}
    patch: |-
      - {op: replace, path: /spec/template/spec/containers/0/resources/requests/cpu, value: "1"}
      - {op: replace, path: /spec/template/spec/containers/0/resources/limits/cpu, value: "1"}
EOF
kubectl kustomize "$work" >"$work/pods.yaml"
mkdir -p "$work/pods"
python3 "$here/pods_for_podman.py" "$work/pods.yaml" "$work/pods" "$SWEEP_K8S_IMAGE"
# The Service: its name resolves inside the pods' network namespace, which nothing else reaches.
printf '127.0.0.1 localhost sweep-coordinator\n' >"$work/pods/hosts"
hosts=(-v "$work/pods/hosts:/etc/hosts:ro")
mapfile -d '' coordinator <"$work/pods/sweep-coordinator.run"
mapfile -d '' worker <"$work/pods/sweep-worker.run"
podman run -d --name sweep-k8s-coordinator --network=none "${hosts[@]}" "${coordinator[@]}" >/dev/null
podman run -d --name sweep-k8s-worker --network=container:sweep-k8s-coordinator "${hosts[@]}" "${worker[@]}" >/dev/null
client() { # sweep in the pods' network, with the worker's token and CA
    podman run --rm --network=container:sweep-k8s-coordinator "${hosts[@]}" --user 65532:65532 \
        -v "$work/pods/sweep-worker/token:/etc/sweep/token:ro" -v "$work/pods/sweep-worker/ca:/etc/sweep/tls:ro" \
        "$SWEEP_K8S_IMAGE" "$@" --coordinator https://sweep-coordinator:7070 \
        --token-file /etc/sweep/token/token --ca /etc/sweep/tls/ca.crt
}
for _ in $(seq 50); do client submit /usr/share/sweep/plans/noop.toml >/dev/null 2>&1 && break; sleep 0.2; done
status=
for _ in $(seq 120); do
    status=$(client status --format json) || break
    grep -q '"done": 1000' <<<"$status" && break
    sleep 1
done
grep -q '"done": 1000' <<<"$status" || { echo "not done: $status"; podman logs sweep-k8s-worker; exit 1; }
cores=$(client workers --format json | python3 -c 'import json, sys; print([w["cores"] for w in json.load(sys.stdin)])')
[[ $cores =~ ^\[\[[0-9]+\]\]$ ]] || { echo "expected one worker on one core (its CPU limit): $cores"; exit 1; }
podman stop -t 30 sweep-k8s-worker sweep-k8s-coordinator >/dev/null
[[ $(podman inspect sweep-k8s-worker --format '{{.State.ExitCode}}') == 0 ]] || { echo "the worker did not stop cleanly"; exit 1; }
[[ $(stat -c %u "$work/pods/sweep-coordinator/data/campaign.db") == 65532 ]]
echo "the pods ran in podman: noop.toml's 1000 points over TLS to sweep-coordinator:7070, the worker on cores $cores (its CPU limit), the database on the volume as uid 65532"
