"""Scene load for bench/run_latency.sh: for `seconds`, upload a 10 MB mesh (a 500 x 500
height field far from the devices), then edit and remove it, again and again, through
the control channel. Prints one JSON line: uploads done and their mean time."""

import argparse
import json
import time

import hapticd
import numpy as np


def height_field(n: int = 500) -> tuple[np.ndarray, np.ndarray]:
    """An n x n grid 5 m away from the default scene: 2 (n-1)^2 triangles."""
    x, y = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    vertices = np.stack([x.ravel() + 5, y.ravel(), 0.01 * np.sin(20 * x.ravel())], axis=1)
    i = (np.arange(n - 1)[:, None] * n + np.arange(n - 1)[None, :]).ravel()
    triangles = np.concatenate([np.stack([i, i + 1, i + n], 1), np.stack([i + 1, i + n + 1, i + n], 1)])
    return vertices, triangles


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--server", required=True)
    parser.add_argument("--seconds", type=float, required=True)
    args = parser.parse_args()
    vertices, triangles = height_field()
    upload_s = []
    with hapticd.connect(args.server, timeout_s=60) as client:
        deadline = time.monotonic() + args.seconds
        while time.monotonic() < deadline:
            started = time.monotonic()
            client.add_mesh("terrain", vertices, triangles, "mesh")
            upload_s.append(time.monotonic() - started)
            client.set_material("terrain", {"stiffness": 3000})
            client.remove_object("terrain")
    print(json.dumps({"uploads": len(upload_s), "mesh_mb": round((vertices.nbytes + triangles.nbytes / 2) / 1e6, 1),
                      "upload_s_mean": round(float(np.mean(upload_s)), 3)}))


if __name__ == "__main__":
    main()
