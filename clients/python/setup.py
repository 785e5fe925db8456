"""The package's build hook: the protocol's Python code (hapticd/v1/hapticd_pb2.py and
its .pyi stub) is generated while building, from ../../proto/hapticd/v1/hapticd.proto,
by protoc (Debian's protobuf-compiler, the one that compiles the server's C++ code from
the same file), so a wheel, and `pip install clients/python`, carry it. An editable
install gets it in src/ (as deploy/install.sh writes it). Everything else about the
package is in pyproject.toml.
"""

import pathlib
import shutil
import subprocess

from setuptools import setup
from setuptools.command.build_py import build_py

HERE = pathlib.Path(__file__).resolve().parent
PROTO_ROOT = HERE.parent.parent / "proto"
PROTO = PROTO_ROOT / "hapticd" / "v1" / "hapticd.proto"
GENERATED = ("hapticd/v1/hapticd_pb2.py", "hapticd/v1/hapticd_pb2.pyi")


def generate(out: pathlib.Path) -> None:
    """Writes the generated modules under out; SystemExit saying what is missing."""
    protoc = shutil.which("protoc")
    if protoc is None:
        raise SystemExit("hapticd: building needs protoc (apt-get install protobuf-compiler)")
    if not PROTO.is_file():
        raise SystemExit(f"hapticd: building needs the protocol's definition, {PROTO}")
    out.mkdir(parents=True, exist_ok=True)
    subprocess.run(
        [protoc, f"-I{PROTO_ROOT}", f"--python_out={out}", f"--pyi_out={out}", str(PROTO)],
        check=True,
    )


class BuildPyWithProtocol(build_py):
    """build_py, then the protocol's modules beside the package's own."""

    def run(self) -> None:
        super().run()
        if self.editable_mode:
            generate(HERE / "src")
            return
        if PROTO.is_file() or not all((HERE / "src" / name).is_file() for name in GENERATED):
            generate(pathlib.Path(self.build_lib))
            return
        # no .proto beside this tree (an unpacked sdist): ship what was generated
        for name in GENERATED:
            target = pathlib.Path(self.build_lib) / name
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(HERE / "src" / name, target)


setup(cmdclass={"build_py": BuildPyWithProtocol})
