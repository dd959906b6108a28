"""Tests of scripts/prerequisites.sh on a PATH of stubs: which tools are there, whether the
user is root, whether sudo and apt-get exist and what apt-get does are all made up, so
nothing is installed and the machine's own tools do not matter.

    python3 -m unittest discover -s tools -p 'test_*.py' -v
"""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
import unittest
from pathlib import Path

SCRIPT = Path(__file__).resolve().parent.parent / "scripts" / "prerequisites.sh"
TOOLS = {
    "ffmpeg": "ffmpeg",
    "ffprobe": "ffmpeg",
    "chromium": "chromium",
    "Xvfb": "xvfb",
    "xwd": "x11-apps",
    "xdotool": "xdotool",
    "npm": "npm",
    "exiftool": "libimage-exiftool-perl",
    # Not a command: python3 importing ensurepip (stubbed as python3 exiting 0 or 1).
    "python3:ensurepip": "python3-venv",
}


def stub_name(tool: str) -> str:
    """The stub that makes `tool` present: its command, or python3 for a module."""
    return "python3" if tool.startswith("python3:") else tool


BASH = shutil.which("bash") or "/bin/bash"
ENV = shutil.which("env") or "/usr/bin/env"
CHMOD = shutil.which("chmod") or "/bin/chmod"


class Prerequisites(unittest.TestCase):
    def setUp(self) -> None:
        self.dir = Path(tempfile.mkdtemp(prefix="prerequisites-test-"))
        self.bin = self.dir / "bin"
        self.bin.mkdir()
        self.log = self.dir / "apt.log"
        os.symlink(ENV, self.bin / "env")

    def tearDown(self) -> None:
        shutil.rmtree(self.dir)

    def stub(self, name: str, body: str = "exit 0") -> None:
        path = self.bin / name
        path.write_text(f"#!{BASH}\n{body}\n")
        path.chmod(0o755)

    def machine(self, missing=(), uid=0, sudo=False, apt="installs") -> None:
        """The made-up machine: every tool but `missing`; apt-get absent (None), failing
        ("fails"), doing nothing ("noop") or installing what it is asked ("installs")."""
        for tool in TOOLS:
            if tool not in missing:
                self.stub(stub_name(tool))
            elif tool.startswith("python3:"):
                self.stub("python3", "exit 1")
        self.stub("id", f'[ "$1" = -u ] && echo {uid}')
        if sudo:
            self.stub("sudo", f'echo "sudo $*" >> {self.log}; exec "$@"')
        if apt is None:
            return
        installs = ""
        for package in dict.fromkeys(TOOLS.values()):
            made = "".join(
                f'printf "#!{BASH}\\n" > {self.bin}/{stub_name(t)}; '
                f"{CHMOD} +x {self.bin}/{stub_name(t)}; "
                for t, p in TOOLS.items()
                if p == package
            )
            installs += f'  *" {package} "*) {made};;\n'
        body = f'echo "apt-get $*" >> {self.log}\n'
        if apt == "fails":
            body += "exit 100"
        elif apt == "installs":
            body += 'for p in "$@"; do case " $p " in\n' + installs + "esac; done"
        self.stub("apt-get", body)

    def run_script(self, *args: str) -> subprocess.CompletedProcess:
        env = {"PATH": str(self.bin), "HOME": str(self.dir)}
        return subprocess.run(
            [BASH, str(SCRIPT), *args], env=env, capture_output=True, text=True, timeout=60
        )

    def apt_calls(self) -> list:
        return self.log.read_text().splitlines() if self.log.exists() else []

    def test_all_present_installs_nothing(self) -> None:
        self.machine()
        r = self.run_script()
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("all present", r.stdout)
        self.assertEqual(self.apt_calls(), [])

    def test_missing_exiftool_is_installed_as_root(self) -> None:
        self.machine(missing=["exiftool"])
        r = self.run_script()
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        self.assertIn("missing exiftool (apt packages: libimage-exiftool-perl)", r.stdout)
        self.assertIn("installing with apt-get: libimage-exiftool-perl", r.stdout)
        calls = self.apt_calls()
        self.assertEqual(calls[0], "apt-get update -qq")
        self.assertRegex(calls[1], r"^apt-get install -y -qq --no-install-recommends libimage-exiftool-perl$")
        self.assertTrue((self.bin / "exiftool").exists())

    def test_a_python_without_venv_gets_python3_venv(self) -> None:
        self.machine(missing=("python3:ensurepip",))
        out = self.run_script()
        self.assertEqual(out.returncode, 0, out.stderr)
        self.assertIn("missing python3:ensurepip (apt packages: python3-venv)", out.stdout)
        self.assertIn(
            "apt-get install -y -qq --no-install-recommends python3-venv", self.apt_calls()
        )

    def test_each_package_once_in_order(self) -> None:
        self.machine(missing=["ffmpeg", "ffprobe", "npm", "Xvfb"])
        r = self.run_script()
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        self.assertIn("installing with apt-get: ffmpeg xvfb npm\n", r.stdout)

    def test_sudo_when_not_root(self) -> None:
        self.machine(missing=["chromium", "xwd"], uid=1000, sudo=True)
        r = self.run_script()
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        self.assertIn("installing with sudo apt-get: chromium x11-apps", r.stdout)
        calls = self.apt_calls()
        self.assertIn("sudo apt-get update -qq", calls)
        self.assertIn(
            "sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends chromium x11-apps",
            calls,
        )

    def test_neither_root_nor_sudo_names_the_packages(self) -> None:
        self.machine(missing=["exiftool", "xdotool"], uid=1000, sudo=False)
        r = self.run_script()
        self.assertEqual(r.returncode, 1)
        self.assertIn("not root and no sudo", r.stderr)
        self.assertIn("apt-get install xdotool libimage-exiftool-perl", r.stderr)
        self.assertEqual(self.apt_calls(), [])

    def test_no_apt_get(self) -> None:
        self.machine(missing=["npm"], apt=None)
        r = self.run_script()
        self.assertEqual(r.returncode, 1)
        self.assertIn("no apt-get here", r.stderr)
        self.assertIn("npm", r.stderr)

    def test_apt_get_failing(self) -> None:
        self.machine(missing=["npm"], apt="fails")
        r = self.run_script()
        self.assertEqual(r.returncode, 1)
        self.assertIn("apt-get failed", r.stderr)

    def test_still_missing_after_the_install(self) -> None:
        self.machine(missing=["Xvfb"], apt="noop")
        r = self.run_script()
        self.assertEqual(r.returncode, 1)
        self.assertIn("still missing after the install: Xvfb (apt packages: xvfb)", r.stderr)

    def test_check_only_installs_nothing(self) -> None:
        self.machine(missing=["exiftool"])
        r = self.run_script("--check")
        self.assertEqual(r.returncode, 1)
        self.assertIn("missing exiftool", r.stdout)
        self.assertEqual(self.apt_calls(), [])
        self.machine()
        self.assertEqual(self.run_script("--check").returncode, 0)


if __name__ == "__main__":
    unittest.main()
