#!/usr/bin/env bash
# Offline checks of the Kubernetes manifests, no cluster needed:
#   1. renders them with `kubectl kustomize`, with throw-away secret files (a token and a
#      self-signed CA + coordinator certificate made here with openssl);
#   2. validates every rendered object against the API schemas with `kubernetes-validate --strict`
#      (PyPI; installed with pip when missing) for the Kubernetes versions below;
#   3. checks that every flag the containers pass is one the sweep binary accepts.
# Usage: deploy/kubernetes/validate.sh [path/to/sweep]   (default: target/release/sweep)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
sweep=${1:-$here/../../target/release/sweep}
versions=(1.30.0 1.37.0)
command -v kubectl >/dev/null || { echo "needs kubectl (for kustomize)" >&2; exit 2; }
command -v kubernetes-validate >/dev/null || pip install -q kubernetes-validate

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
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
