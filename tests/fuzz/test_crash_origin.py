#!/usr/bin/python3
"""crash_origin.py, which run.sh uses to accept libhdf5's own crashes, on reports shaped like the
ones `make fuzz` saw: it must name libhdf5 only when libhdf5 is the first frame outside the
sanitizer runtime, libFuzzer, allocators and libc, and name wmkit's file otherwise."""
import io
import os
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from crash_origin import origin  # noqa: E402

BIN = "(/b/fuzz_hdf5+0x1240ae) (BuildId: 17)"
HDF5 = "(/lib/x86_64-linux-gnu/libhdf5_serial.so.103+0x1233e4) (BuildId: e9)"
LIBC = "(/lib/x86_64-linux-gnu/libc.so.6+0x3c04f) (BuildId: 93)"

OOM_IN_HDF5 = f"""==5702== ERROR: libFuzzer: out-of-memory (used: 2506Mb; limit: 2048Mb)
Live Heap Allocations: 1000684378 bytes in 30405547 chunks
    #0 0x5636d1ebf0ae in malloc {BIN}
    #1 0x7f02889233e4  {HDF5}
"""
TIMEOUT_IN_HDF5 = f"""==5503== ERROR: libFuzzer: timeout after 3 seconds
    #0 0x556d98305191 in __sanitizer_print_stack_trace {BIN}
    #1 0x556d98277ae8 in fuzzer::PrintStackTrace() {BIN}
    #2 0x556d9825d329 in fuzzer::Fuzzer::AlarmCallback() {BIN}
    #3 0x7fddd0d7a04f  {LIBC}
    #4 0x7fddd1169968  {HDF5}
    #5 0x556d983a19c9 in wm::ingest::h5::ReadStringAttr(long, char const*) /w/ingest/hdf5/hdf5_file.cc:85:11
"""
OVERFLOW_IN_WMKIT = f"""==5509==ERROR: AddressSanitizer: heap-buffer-overflow on address 0x60b0000117d0
READ of size 8
    #0 0x55818427a4b3 in __interceptor_memcpy {BIN}
    #1 0x55818438928b in wm::ingest::h5::ReadStringAttr(long, char const*) /w/ingest/hdf5/hdf5_file.cc:72:7
    #2 0x7f123f45c350 in H5Aexists {HDF5}
"""


def run(text):
    return origin(io.StringIO(text))


class CrashOriginTest(unittest.TestCase):
    def test_allocation_inside_libhdf5(self):
        self.assertEqual(run(OOM_IN_HDF5), "libhdf5_serial.so.103")

    def test_hang_inside_libhdf5_skips_the_alarm_handler_frames(self):
        self.assertEqual(run(TIMEOUT_IN_HDF5), "libhdf5_serial.so.103")

    def test_wmkit_frame_above_libhdf5_is_wmkits(self):
        self.assertEqual(run(OVERFLOW_IN_WMKIT), "hdf5_file.cc:72:7")

    def test_frames_before_the_error_line_are_ignored(self):
        # A stack printed before the report (e.g. a logged warning) is not the failure's.
        self.assertEqual(run(f"    #0 0x1  {HDF5}\n" + OVERFLOW_IN_WMKIT), "hdf5_file.cc:72:7")

    def test_only_runtime_frames_is_unknown(self):
        self.assertIsNone(run(f"==1==ERROR: x\n    #0 0x1 in malloc {BIN}\n    #1 0x2  {LIBC}\n"))


if __name__ == "__main__":
    unittest.main()
