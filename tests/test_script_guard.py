"""A study (or an evaluation on workers) called from a plain script without
``if __name__ == "__main__":``: Dask's worker processes import the script again and would run it
again. Refused before any worker starts, in one line that says what to write."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from tiny_study import tiny_study

PROBE = "from astrocpg.studies.runtime.cluster import unguarded_call\n"


def _run(tmp_path: Path, text: str) -> subprocess.CompletedProcess:
    script = tmp_path / "script.py"
    script.write_text(text)
    return subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                          cwd=tmp_path, timeout=300)


@pytest.mark.parametrize("text, line", [
    (PROBE + "print(unguarded_call())\n", 2),
    (PROBE + "def go():\n    return unguarded_call()\n\nprint(go())\n", 5),
    (PROBE + "if __name__ == '__main__':\n    print(unguarded_call())\n", None),
    (PROBE + "def go():\n    return unguarded_call()\n\nif '__main__' == __name__:\n"
             "    print(go())\n", None),
])
def test_the_call_is_found_where_the_script_runs_it(tmp_path, text, line) -> None:
    proc = _run(tmp_path, text)
    assert proc.returncode == 0, proc.stderr
    expected = "None" if line is None else repr((str(tmp_path / "script.py"), line))
    assert proc.stdout.strip() == expected


def test_a_study_in_an_unguarded_script_says_what_to_write(tmp_path) -> None:
    (tmp_path / "t.toml").write_text(tiny_study("t", sessions=1))
    proc = _run(tmp_path, "import astrocpg as ac\n"
                          "ac.study('t.toml', out='s', workers=1, progress=False)\n")
    assert proc.returncode == 1
    last = proc.stderr.strip().splitlines()[-1]
    assert "InputError" in last and 'if __name__ == "__main__":' in last, proc.stderr
    assert "script.py: line 2" in last
    assert "Nanny" not in proc.stderr and "distributed" not in proc.stderr, proc.stderr
    assert not (tmp_path / "s").exists()
