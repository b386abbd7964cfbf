"""What the script-style Python tests share (tests/policy/test_openpi_policy.py,
tests/train/test_wm_train_cli.py): named checks that print as they go and a summary that is the
exit status, and a free local TCP port for the servers they start."""
import socket


class CheckList:
    def __init__(self):
        self.names, self.failures = [], []

    def __call__(self, ok, what):
        """Records check `what`; prints ok / FAIL at once, so a hang shows how far it got."""
        self.names.append(what)
        if not ok:
            self.failures.append(what)
        print(("ok   " if ok else "FAIL ") + what)

    def summary(self):
        """Prints the counts; -> the exit status (1 when any check failed)."""
        print("%d passed, %d failed" % (len(self.names) - len(self.failures), len(self.failures)))
        return 1 if self.failures else 0


def free_port():
    """A TCP port on 127.0.0.1 that nothing listens on now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]
