"""examples/sil-external/law3.py as a flight computer that overruns: before its command of
every period k with k % 10 == 5 it works 60 ms (tests/sil/test_realtime.py)."""

import importlib.util
import sys
import time
from pathlib import Path

OVERRUN_S = 0.06

spec = importlib.util.spec_from_file_location("law3", Path(__file__).resolve().parents[2] / "examples" / "sil-external" / "law3.py")
law3 = importlib.util.module_from_spec(spec)
spec.loader.exec_module(law3)
_send = law3.send


def send(sock, message):
    if message["type"] == "command" and message["k"] % 10 == 5:
        time.sleep(OVERRUN_S)
    _send(sock, message)


law3.send = send
sys.exit(law3.main())
