#!/usr/bin/python3
"""Prints where a sanitizer or libFuzzer report says a failure happened: the library (e.g.
libhdf5_serial.so.103) or source position (hdf5_file.cc:72:7) of the first stack frame that is
not the sanitizer runtime, libFuzzer, an allocator or a libc routine. run.sh uses it to tell libhdf5's own bugs
(contained by wm-ingest's child process, docs/testing.md) from wmkit's.

  crash_origin.py < report.log      prints the module, or "unknown" (exit 1) when no frame is
                                    left after the runtime's own frames
"""
import os
import re
import sys

FRAME = re.compile(r"^\s*#\d+ 0x[0-9a-f]+\s+(?:in (?P<func>.+?) )?\((?P<module>[^()+]+)\+0x[0-9a-f]+\)")
FRAME_WITH_SOURCE = re.compile(r"^\s*#\d+ 0x[0-9a-f]+ in (?P<func>.+?) (?P<src>/\S+:\d+(:\d+)?)$")
RUNTIME_FUNCS = re.compile(
    r"^(__sanitizer|__asan|__lsan|__ubsan|_?__interceptor_|__interception|fuzzer::|"
    r"operator new|operator delete|"
    r"(malloc|calloc|realloc|free|posix_memalign|aligned_alloc|mem(cpy|move|set|cmp)|"
    r"str(n?len|n?cpy|n?cmp|dup))\b)")
RUNTIME_MODULES = re.compile(r"^(libc\.so|libstdc\+\+\.so|libm\.so|ld-linux|libgcc_s\.so)")


def origin(lines):
    """Module (or source file:line) of the first frame of the first stack trace outside the runtime."""
    started = False
    for line in lines:
        if not started:
            started = "ERROR:" in line
            continue
        m = FRAME.match(line) or FRAME_WITH_SOURCE.match(line)
        if not m:
            continue
        func = m.group("func") or ""
        where = os.path.basename(m.groupdict().get("module") or m.group("src"))
        if RUNTIME_FUNCS.match(func) or RUNTIME_MODULES.match(where):
            continue
        return where
    return None


def main():
    found = origin(sys.stdin)
    print(found or "unknown")
    return 0 if found else 1


if __name__ == "__main__":
    sys.exit(main())
