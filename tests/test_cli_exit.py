"""How the ``acc`` process ends: the exit handlers run, the streams are flushed, the status is
kept, and the interpreter's teardown is skipped only when no other thread runs."""

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _python(code: str) -> subprocess.CompletedProcess:
    # buffered streams, as in a plain shell (the test runner's may set PYTHONUNBUFFERED)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=ROOT, env=env, check=False, timeout=120)


def test_exit_runs_the_handlers_flushes_and_keeps_the_status():
    # stdout is a pipe here, so "partial" sits in the buffer until the flush
    done = _python(
        "import atexit, sys\n"
        "from acc.cli.main import exit_without_teardown\n"
        "atexit.register(lambda: print('handler ran'))\n"
        "print('partial', end='')\n"
        "sys.stderr.write('to stderr')\n"
        "exit_without_teardown(3)\n"
        "print('not reached')\n"
    )
    assert done.returncode == 3
    assert done.stdout == "partialhandler ran\n"
    assert done.stderr == "to stderr"


def test_exit_waits_for_a_running_thread():
    # with a second (non-daemon) thread alive the usual exit joins it: its output arrives
    done = _python(
        "import threading, time\n"
        "from acc.cli.main import exit_without_teardown\n"
        "threading.Thread(target=lambda: (time.sleep(0.3), print('thread done'))).start()\n"
        "exit_without_teardown(4)\n"
    )
    assert done.returncode == 4
    assert done.stdout == "thread done\n"


def test_python_m_acc_keeps_the_error_status_and_line(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[controller]\nkind = 'no_such_kind'\n")
    done = subprocess.run([sys.executable, "-m", "acc", "run", str(bad), "--out",
                           str(tmp_path / "out")], capture_output=True, text=True, cwd=ROOT,
                          check=False, timeout=300)
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("acc: error:") and "no_such_kind" in lines[0]
    assert not (tmp_path / "out").exists()
