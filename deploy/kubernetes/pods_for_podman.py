"""What a kubelet would make of the rendered workloads, for `podman run` (validate.sh, step 4).

For each StatefulSet and Deployment in RENDERED.yaml: its Secrets written as files (with the
volume's defaultMode, group-owned by the pod's fsGroup), its persistent volume as a directory
group-writable by fsGroup, and the `podman run` options and arguments (user, fsGroup, read-only
root, mounts, the image, the container's args with $(VAR) expanded from the downward API) in
OUT/NAME.run, NUL-separated.
Usage: python3 pods_for_podman.py RENDERED.yaml OUT IMAGE
"""

import base64
import math
import os
import re
import sys

import yaml


def cpu_count(quantity: str) -> int:
    """A CPU quantity ("4", "500m") as the downward API gives it with divisor 1: rounded up."""
    return math.ceil(int(quantity[:-1]) / 1000) if quantity.endswith("m") else math.ceil(float(quantity))


def main(rendered: str, out: str, image: str) -> None:
    docs = [d for d in yaml.safe_load_all(open(rendered)) if d]
    secrets = {d["metadata"]["name"]: d["data"] for d in docs if d["kind"] == "Secret"}
    for doc in docs:
        if doc["kind"] not in ("StatefulSet", "Deployment"):
            continue
        name, pod = doc["metadata"]["name"], doc["spec"]["template"]["spec"]
        security = pod.get("securityContext", {})
        fs_group = security.get("fsGroup", 0)
        (container,) = pod["containers"]
        volumes = {v["name"]: v for v in pod.get("volumes", [])}
        for claim in doc["spec"].get("volumeClaimTemplates", []):
            volumes[claim["metadata"]["name"]] = {"persistentVolumeClaim": {}}
        options = ["--user", f'{security["runAsUser"]}:{security["runAsGroup"]}', "--group-add", str(fs_group)]
        if container.get("securityContext", {}).get("readOnlyRootFilesystem"):
            options.append("--read-only")
        for mount in container.get("volumeMounts", []):
            volume, host = volumes[mount["name"]], os.path.join(out, name, mount["name"])
            os.makedirs(host)
            if "secret" in volume:
                data = secrets[volume["secret"]["secretName"]]
                for item in volume["secret"].get("items") or [{"key": k, "path": k} for k in data]:
                    path = os.path.join(host, item["path"])
                    with open(path, "wb") as f:
                        f.write(base64.b64decode(data[item["key"]]))
                    os.chmod(path, volume["secret"].get("defaultMode", 0o644))
                    os.chown(path, 0, fs_group)
            else:
                os.chown(host, 0, fs_group)
                os.chmod(host, 0o2775)
            options += ["-v", f'{host}:{mount["mountPath"]}' + (":ro" if mount.get("readOnly") else "")]
        env = {}
        for var in container.get("env", []):
            field = var.get("valueFrom", {}).get("resourceFieldRef")
            if field:
                kind, resource = field["resource"].split(".")
                env[var["name"]] = str(cpu_count(container["resources"][kind][resource]))
            else:
                env[var["name"]] = var["value"]
        args = [re.sub(r"\$\((\w+)\)", lambda m: env[m.group(1)], a) for a in container["args"]]
        with open(os.path.join(out, name + ".run"), "wb") as f:
            f.write(b"\0".join(x.encode() for x in options + [image] + args))
        print(f"{name}: sweep {' '.join(args)}")


if __name__ == "__main__":
    main(*sys.argv[1:])
