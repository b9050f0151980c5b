"""Writes the .npz/.npy fixtures optik-io's tests read, with whichever numpy runs it.

    python3 -m venv /tmp/np1 && /tmp/np1/bin/pip install "numpy<2" && /tmp/np1/bin/python make.py
    python3 -m venv /tmp/np2 && /tmp/np2/bin/pip install "numpy>=2" && /tmp/np2/bin/python make.py

Files are named after numpy's major version (numpy1-*, numpy2-*). Both numpy 1.26 and 2.4 write
np.savez members with zip64 local headers (sizes 0xFFFFFFFF and a zip64 extra field; numpy passes
force_zip64), which the old hand-written reader in optik-benches read as "truncated npz".
The script prints each member's local-header size field and extra-field length.
"""

import os

import numpy as np

here = os.path.dirname(os.path.abspath(__file__))
major = np.__version__.split(".")[0]


def out(name):
    return os.path.join(here, f"numpy{major}-{name}")


t = np.array([1.5, np.inf, 0.25], dtype=np.float32)
prim = np.array([7, 0xFFFFFFFF, 0], dtype=np.uint32)
rays = np.arange(16, dtype=np.float32).reshape(2, 8)
np.savez(out("hits.npz"), t=t, prim=prim)
np.savez_compressed(out("compressed.npz"), t=t, prim=prim)
np.save(out("rays.npy"), rays)
np.save(out("empty.npy"), np.zeros((0, 8), dtype=np.float32))

with open(out("hits.npz"), "rb") as f:
    head = f.read(30)
size = int.from_bytes(head[18:22], "little")
extra = int.from_bytes(head[28:30], "little")
print(f"numpy {np.__version__}: first member's local size field {size:#x}, extra field {extra} bytes")
