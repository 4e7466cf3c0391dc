"""The command's end without Python's teardown (:mod:`coopsat.core.process_exit`): the status,
the atexit handlers, every byte of output and the program's own threads are what a normal exit
gives."""

import os
import subprocess
import sys
import textwrap

import pytest

from coopsat.core.process_exit import EXIT_FLUSH_FAILED, exit_code


def _run(body):
    code = "from coopsat.core.process_exit import end\n" + textwrap.dedent(body)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}  # stdout buffered, as usual on a pipe
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, env=env)


@pytest.mark.parametrize(("status", "code"), [(None, 0), (0, 0), (3, 3), (130, 130)])
def test_the_status_is_what_sys_exit_gives(status, code):
    assert exit_code(status) == code


def test_a_message_status_is_printed_and_gives_1(capsys):
    assert exit_code("coopsat: stopped") == 1
    assert capsys.readouterr().err == "coopsat: stopped\n"


def test_handlers_run_output_is_whole_and_the_status_kept():
    done = _run("""
        import atexit, sys
        atexit.register(lambda: print("handler ran"))
        sys.stdout.write("x" * 1_000_000)  # more than any pipe buffer: flushed at the end, not lost
        print("on stderr", file=sys.stderr, end="")
        end(3)
        print("never")
    """)
    assert done.returncode == 3
    assert done.stdout == "x" * 1_000_000 + "handler ran\n"
    assert done.stderr == "on stderr"


def test_a_running_thread_is_waited_for_as_a_normal_exit_waits():
    done = _run("""
        import threading, time
        threading.Thread(target=lambda: (time.sleep(0.5), print("thread finished"))).start()
        end(5)
    """)
    assert (done.returncode, done.stdout) == (5, "thread finished\n")


def test_a_reader_gone_before_the_final_flush_gives_python_s_status():
    done = _run("""
        import os, sys
        sys.stdout.write("pending")  # buffered: the flush at the end meets a closed pipe
        read, write = os.pipe()
        os.close(read)
        os.dup2(write, sys.stdout.fileno())
        end(0)
    """)
    assert done.returncode == EXIT_FLUSH_FAILED
