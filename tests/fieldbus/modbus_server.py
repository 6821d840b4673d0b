#!/usr/bin/python3
"""A Modbus server (pymodbus 3.0, Debian's python3-pymodbus) for the Modbus I/O thread's tests (docs/modbus.md).

It holds the four tables (addresses 0..999 each, zero-based) and can misbehave on demand, so the tests see every
failure a real device shows:

  normal      answer every request
  stop        read requests and never answer (a hung device, a cut RS-485 line)
  exception   answer every request with exception code N (default 4, slave device failure)
  late        answer after a delay (default 300 ms; a device slower than the client's response timeout)
  disconnect  close every TCP connection as soon as it is made or sends a request (RTU: close the serial port)

Transport: --tcp HOST:PORT (port 0 = any free one) or --rtu DEVICE [--baud B --parity N|E|O] (for example one end of
a socat pty pair; a pty refuses parity, so the tests use 8N1).
Control: a line protocol on a TCP port of 127.0.0.1 (--control-port, 0 = any free one), one reply line per command:
  mode NAME [ARG]          -> ok          (ARG: exception code, or the delay in ms for late)
  set hr|ir|co|di ADDR V.. -> ok          (set registers / bits)
  get hr|ir|co|di ADDR N   -> V V ..      (read them)
  requests                 -> N           (requests received so far, answered or not)
  quit                     -> ok          (then the server exits)
When ready it prints one line on stdout: "READY modbus_port=P control_port=C" (P is 0 for RTU).
"""

import argparse
import asyncio
import logging
import sys

from pymodbus.datastore import ModbusSequentialDataBlock, ModbusServerContext, ModbusSlaveContext
from pymodbus.server.async_io import (
    ModbusConnectedRequestHandler,
    ModbusSerialServer,
    ModbusSingleRequestHandler,
    ModbusTcpServer,
)
from pymodbus.transaction import ModbusRtuFramer, ModbusSocketFramer

TABLES = {"co": 1, "di": 2, "hr": 3, "ir": 4}  # pymodbus addresses a table by a function code reading it
SIZE = 1000


class State:
    mode = "normal"
    exception_code = 4
    late_s = 0.3
    requests = 0
    serial_server = None


class FaultInjection:
    """Mixed into pymodbus's request handlers: decides per request what the server does with it."""

    def connection_made(self, transport):
        super().connection_made(transport)
        if State.mode == "disconnect" and State.serial_server is None:
            transport.close()

    def execute(self, request, *addr):
        State.requests += 1
        mode = State.mode
        if mode == "stop":
            return
        if mode == "disconnect":
            self.transport.close()
            return
        if mode == "exception":
            response = request.doException(State.exception_code)
            response.transaction_id = request.transaction_id
            response.unit_id = request.unit_id
            self.send(response, *addr)
            return
        if mode == "late":
            asyncio.get_running_loop().call_later(State.late_s, self._late, request, addr)
            return
        super().execute(request, *addr)

    def _late(self, request, addr):
        if self.transport is not None and not self.transport.is_closing():
            super().execute(request, *addr)


class TcpHandler(FaultInjection, ModbusConnectedRequestHandler):
    pass


class SerialHandler(FaultInjection, ModbusSingleRequestHandler):
    pass


def make_context(unit):
    store = ModbusSlaveContext(
        di=ModbusSequentialDataBlock(0, [0] * SIZE),
        co=ModbusSequentialDataBlock(0, [0] * SIZE),
        hr=ModbusSequentialDataBlock(0, [0] * SIZE),
        ir=ModbusSequentialDataBlock(0, [0] * SIZE),
        zero_mode=True,
    )
    return ModbusServerContext(slaves={unit: store}, single=False), store


def handle_command(line, store):
    words = line.split()
    if not words:
        return "error empty command"
    cmd = words[0]
    try:
        if cmd == "mode":
            if words[1] not in ("normal", "stop", "exception", "late", "disconnect"):
                return "error unknown mode " + words[1]
            State.mode = words[1]
            if len(words) > 2 and State.mode == "exception":
                State.exception_code = int(words[2])
            if len(words) > 2 and State.mode == "late":
                State.late_s = float(words[2]) / 1000.0
            if State.mode == "disconnect" and State.serial_server is not None:
                transport = State.serial_server.transport
                if transport is not None:
                    transport.close()
            return "ok"
        if cmd == "set":
            values = [int(v) for v in words[3:]]
            store.setValues(TABLES[words[1]], int(words[2]), values)
            return "ok"
        if cmd == "get":
            values = store.getValues(TABLES[words[1]], int(words[2]), int(words[3]))
            return " ".join(str(int(v)) for v in values)
        if cmd == "requests":
            return str(State.requests)
        if cmd == "quit":
            return "ok"
    except (IndexError, KeyError, ValueError) as exc:
        return "error " + repr(exc)
    return "error unknown command " + cmd


async def control_client(reader, writer, store, done):
    while True:
        line = await reader.readline()
        if not line:
            break
        text = line.decode().strip()
        writer.write((handle_command(text, store) + "\n").encode())
        await writer.drain()
        if text == "quit":
            done.set()
            break
    writer.close()


async def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--tcp", metavar="HOST:PORT")
    group.add_argument("--rtu", metavar="DEVICE")
    parser.add_argument("--baud", type=int, default=19200)
    parser.add_argument("--parity", choices=("N", "E", "O"), default="N")
    parser.add_argument("--unit", type=int, default=1)
    parser.add_argument("--control-port", type=int, default=0)
    parser.add_argument("--verbose", action="store_true")
    args = parser.parse_args()
    logging.basicConfig(level=logging.DEBUG if args.verbose else logging.CRITICAL)
    # pymodbus logs every closed connection as an error: the tests close many on purpose.
    logging.getLogger("pymodbus").setLevel(logging.DEBUG if args.verbose else logging.CRITICAL)

    context, store = make_context(args.unit)
    done = asyncio.Event()
    control = await asyncio.start_server(
        lambda r, w: control_client(r, w, store, done), "127.0.0.1", args.control_port
    )
    control_port = control.sockets[0].getsockname()[1]

    if args.tcp:
        host, port = args.tcp.rsplit(":", 1)
        server = ModbusTcpServer(
            context, framer=ModbusSocketFramer, address=(host, int(port)), handler=TcpHandler,
            allow_reuse_address=True,
        )
        task = asyncio.create_task(server.serve_forever())
        await server.serving
        modbus_port = server.server.sockets[0].getsockname()[1]
    else:
        server = ModbusSerialServer(
            context, framer=ModbusRtuFramer, port=args.rtu, baudrate=args.baud, handler=SerialHandler,
            parity=args.parity, stopbits=1, bytesize=8, timeout=0,
        )
        State.serial_server = server
        await server.start()
        if server.transport is None:
            print("cannot open " + args.rtu, file=sys.stderr)
            sys.exit(1)
        task = None
        modbus_port = 0

    print(f"READY modbus_port={modbus_port} control_port={control_port}", flush=True)
    await done.wait()
    if task is not None:
        await server.shutdown()
        task.cancel()
    else:
        await server.shutdown()
    control.close()


if __name__ == "__main__":
    asyncio.run(main())
