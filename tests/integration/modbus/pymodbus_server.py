#!/usr/bin/python3
"""Independent Modbus TCP peer for the acquisition tests (Debian python3-pymodbus 3.0.0).

    /usr/bin/python3 pymodbus_server.py PORT SPEC.json

SPEC.json is a list of {"address", "type", "byte_order", "word_order", "value"}. Each value is
encoded here with Python's struct module (big-endian bytes A B C D) and laid out on the wire as
AB/BA or ABCD/CDAB/BADC/DCBA, independently of the C++ code; holding and input registers both
serve the pattern (addresses 0-based, zero_mode=True).
"""
import json
import logging
import os
import struct
import sys

from pymodbus.datastore import (ModbusSequentialDataBlock, ModbusServerContext,
                                ModbusSlaveContext)
from pymodbus.server import StartTcpServer

FORMATS = {"int16": ">h", "uint16": ">H", "int32": ">i", "uint32": ">I", "float32": ">f"}


def layout(byte_order, word_order, nbytes):
    if nbytes == 2:
        return "AB" if byte_order == "big" else "BA"
    if byte_order == "big":
        return "ABCD" if word_order == "big" else "CDAB"
    return "BADC" if word_order == "big" else "DCBA"


def main():
    # The test probes the port with bare connects until the server is up; pymodbus logs each
    # one as an error. Set KM_PYMODBUS_VERBOSE=1 to see its log.
    if not os.environ.get("KM_PYMODBUS_VERBOSE"):
        logging.getLogger("pymodbus").setLevel(logging.CRITICAL)
    port = int(sys.argv[1])
    with open(sys.argv[2], encoding="utf-8") as f:
        spec = json.load(f)
    registers = [0] * 200
    for e in spec:
        value = e["value"]
        if e["type"] != "float32":
            value = int(value)
        raw = struct.pack(FORMATS[e["type"]], value)
        wire = bytes(raw[ord(c) - ord("A")] for c in layout(e["byte_order"], e["word_order"], len(raw)))
        for r in range(len(wire) // 2):
            registers[e["address"] + r] = (wire[2 * r] << 8) | wire[2 * r + 1]
    store = ModbusSlaveContext(hr=ModbusSequentialDataBlock(0, list(registers)),
                               ir=ModbusSequentialDataBlock(0, list(registers)),
                               zero_mode=True)
    context = ModbusServerContext(slaves=store, single=True)
    StartTcpServer(context=context, address=("127.0.0.1", port))


if __name__ == "__main__":
    main()
