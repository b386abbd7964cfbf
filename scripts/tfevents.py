#!/usr/bin/python3
"""Independent reader for TensorBoard event files, written from the TFRecord framing and the
protobuf wire format (no TensorFlow, TensorBoard or protobuf package), for checking what the
trainers write without TensorBoard (docs/tensorboard.md).

  tfevents.py RUN_DIR/events.out.tfevents.metrics     one line per scalar: step tag value
  tfevents.py RUN_DIR/events.out.tfevents.val_images  one line per image: step tag WxH png N bytes

Bad data raises ValueError naming the file and the record; exit 1.
"""
import struct
import sys

import crc32c  # Debian python3-crc32c

FILE_VERSION = "brain.Event:2"


def masked_crc(data):
    crc = crc32c.crc32c(data)
    return (((crc >> 15) | (crc << 17)) + 0xA282EAD8) & 0xFFFFFFFF


def read_records(path):
    """The records of a TFRecord file, each CRC-checked."""
    with open(path, "rb") as f:
        blob = f.read()
    pos, records = 0, []
    while pos < len(blob):
        where = f"{path}: record {len(records)} at byte {pos}"
        if len(blob) - pos < 12:
            raise ValueError(f"{where}: truncated length")
        (n,) = struct.unpack_from("<Q", blob, pos)
        if struct.unpack_from("<I", blob, pos + 8)[0] != masked_crc(blob[pos:pos + 8]):
            raise ValueError(f"{where}: length CRC mismatch")
        data = blob[pos + 12:pos + 12 + n]
        if len(blob) < pos + 16 + n:
            raise ValueError(f"{where}: truncated record")
        if struct.unpack_from("<I", blob, pos + 12 + n)[0] != masked_crc(data):
            raise ValueError(f"{where}: data CRC mismatch")
        records.append(data)
        pos += 16 + n
    return records


def decode_fields(msg):
    """{field number: [values]} of one protobuf message: ints for varints, bytes for
    length-delimited, raw 8 / 4 bytes for fixed64 / fixed32."""
    fields, pos = {}, 0

    def varint():
        nonlocal pos
        shift = value = 0
        while True:
            b = msg[pos]
            pos += 1
            value |= (b & 0x7F) << shift
            shift += 7
            if b < 0x80:
                return value

    while pos < len(msg):
        key = varint()
        number, wire = key >> 3, key & 7
        if wire == 0:
            value = varint()
        elif wire in (1, 5):
            size = 8 if wire == 1 else 4
            value, pos = msg[pos:pos + size], pos + size
        elif wire == 2:
            n = varint()
            value, pos = msg[pos:pos + n], pos + n
        else:
            raise ValueError(f"unsupported wire type {wire}")
        fields.setdefault(number, []).append(value)
    return fields


def decode_event(record):
    """{"wall_time", "step", "file_version" or None, "scalars": {tag: float}, "images": {tag:
    {"height", "width", "colorspace", "png"}}} of one Event (event.proto: wall_time 1, step 2,
    file_version 3, summary 5; summary.proto: value 1 {tag 1, simple_value 2, image 4 {height 1,
    width 2, colorspace 3, encoded_image_string 4}})."""
    f = decode_fields(record)
    step = f.get(2, [0])[0]
    event = {"wall_time": struct.unpack("<d", f[1][0])[0],
             "step": step - (1 << 64) if step >= 1 << 63 else step,
             "file_version": f[3][0].decode() if 3 in f else None, "scalars": {}, "images": {}}
    for summary in f.get(5, []):
        for value in decode_fields(summary).get(1, []):
            v = decode_fields(value)
            tag = v[1][0].decode()
            if 4 in v:
                image = decode_fields(v[4][0])
                event["images"][tag] = {"height": image[1][0], "width": image[2][0],
                                        "colorspace": image[3][0], "png": image[4][0]}
            else:
                event["scalars"][tag] = struct.unpack("<f", v[2][0])[0]
    return event


def read_events(path):
    return [decode_event(r) for r in read_records(path)]


def main(argv):
    try:
        for event in read_events(argv[1]):
            for tag, value in event["scalars"].items():
                print(event["step"], tag, value)
            for tag, image in event["images"].items():
                print(event["step"], tag, f"{image['width']}x{image['height']} png",
                      len(image["png"]), "bytes")
    except (ValueError, IndexError, KeyError, OSError) as e:
        print(f"tfevents.py: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
