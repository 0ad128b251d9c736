"""``navstack link monitor`` / ``link replay`` (bring-up of a vehicle link) and
``navstack drive`` (a vehicle driver on real hardware)."""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from navstack.core.errors import NavstackError
from navstack.interfaces.cli.common import app, fail, parse_cmd

if TYPE_CHECKING:
    from navstack.drivers.framing import Framer
    from navstack.drivers.transport import Transport

link_app = typer.Typer(help="Vehicle links: watch decoded packets live, replay a packet log.",
                       no_args_is_help=True)
app.add_typer(link_app, name="link")

UdpOpt = Annotated[int | None, typer.Option("--udp", help="Listen on this UDP port "
                                            "(0.0.0.0).")]
SerialOpt = Annotated[str | None, typer.Option("--serial", help="Serial device (or pty / "
                                               "symlink / pyserial URL such as loop://).")]


def _transport(udp: int | None, serial: str | None, baud: int, framer: Framer,
               remote: str | None = None) -> Transport:
    from navstack.drivers.transport import SerialTransport, UdpTransport, parse_endpoint

    if (udp is None) == (serial is None):
        raise fail("give exactly one of --udp PORT or --serial DEVICE")
    if udp is not None:
        if not 0 <= udp <= 65535:
            raise fail(f"--udp {udp}: a port is 0..65535")
        target = parse_endpoint(remote, "--to") if remote else None
        return UdpTransport("udp", ("0.0.0.0", udp), target, framer)
    assert serial is not None
    return SerialTransport("serial", serial, baud, framer)


@link_app.command("monitor")
def monitor(
    udp: UdpOpt = None,
    serial: SerialOpt = None,
    baud: Annotated[int, typer.Option(help="Serial baud rate.")] = 115200,
    protocol: Annotated[str | None, typer.Option(
        help="rover_vcu, golf_cart, cart_sensors or gnss (default: rover_vcu on --udp, "
             "cart_sensors on --serial).")] = None,
    count: Annotated[int | None, typer.Option(help="Stop after this many packets.")] = None,
    duration: Annotated[float | None, typer.Option(help="Stop after this many "
                                                   "seconds.")] = None,
    log: Annotated[Path | None, typer.Option(help="Also record every packet to this "
                                             "packet log (JSON Lines; replay it with "
                                             "`navstack link replay`).")] = None,
) -> None:
    """Print every packet a link receives, decoded (or MALFORMED with the reason)."""
    from navstack.drivers.monitor import PacketDescriber
    from navstack.drivers.packet_log import LoggedPacket, PacketLogWriter

    proto = protocol or ("rover_vcu" if udp is not None else "cart_sensors")
    try:
        describer = PacketDescriber(proto, datagrams=udp is not None)
        transport = _transport(udp, serial, baud, describer.framer())
        transport.open()
    except NavstackError as exc:
        raise fail(str(exc)) from None
    source = f"udp:{udp}" if udp is not None else f"serial:{serial}"
    typer.echo(f"monitoring {source} ({proto}); Ctrl-C to stop")
    stream = log.open("w", encoding="utf-8") if log is not None else None
    writer = PacketLogWriter(stream, source, proto) if stream is not None else None
    t0 = time.monotonic()
    seen = 0
    try:
        while (count is None or seen < count) and \
                (duration is None or time.monotonic() - t0 < duration):
            for packet in transport.poll(0.05):
                t = time.monotonic() - t0
                typer.echo(f"{t:9.3f}  {describer.describe(packet)}")
                if writer is not None:
                    writer.write(LoggedPacket(t, transport.name, "rx", packet))
                seen += 1
                if count is not None and seen >= count:
                    break
    except KeyboardInterrupt:
        pass
    finally:
        transport.close()
        if stream is not None:
            stream.close()
    s = transport.stats
    typer.echo(f"{seen} packets: {describer.ok} decoded, {describer.malformed} malformed, "
               f"{s.framing_dropped_bytes} bytes dropped by framing, {s.io_errors} I/O errors"
               + (f"; logged to {log}" if log is not None else ""))


@link_app.command("replay")
def replay(
    log: Annotated[Path, typer.Argument(
        help="Packet log (JSON Lines, as `navstack link monitor` records it).")],
    to: Annotated[str | None, typer.Option("--to", help="Send UDP datagrams to ip:port.")
                  ] = None,
    serial: SerialOpt = None,
    baud: Annotated[int, typer.Option(help="Serial baud rate.")] = 115200,
    rate: Annotated[float, typer.Option(help="Speed factor (2 = twice as fast; 0 = as fast "
                                        "as possible).")] = 1.0,
    direction: Annotated[str, typer.Option("--dir", help="Which packets: rx (what the "
                                           "recorder received), tx or all.")] = "rx",
) -> None:
    """Send a recorded packet log with its original timing."""
    from navstack.drivers.framing import DatagramFramer
    from navstack.drivers.packet_log import read_packet_log

    if direction not in ("rx", "tx", "all"):
        raise fail(f"--dir must be rx, tx or all, got {direction!r}")
    if rate < 0 or not math.isfinite(rate):
        raise fail(f"--rate must be >= 0, got {rate}")
    if (to is None) == (serial is None):
        raise fail("give exactly one of --to IP:PORT or --serial DEVICE")
    try:
        _, packets = read_packet_log(log)
        transport = _transport(0 if to is not None else None, serial, baud, DatagramFramer(),
                               remote=to)
        transport.open()
    except NavstackError as exc:
        raise fail(str(exc)) from None
    chosen = [p for p in packets if direction == "all" or p.direction == direction]
    t0 = time.monotonic()
    sent = 0
    try:
        for p in chosen:
            if rate > 0:
                delay = p.t / rate - (time.monotonic() - t0)
                if delay > 0:
                    time.sleep(delay)
            sent += int(transport.write(p.data))
    finally:
        transport.close()
    typer.echo(f"sent {sent} of {len(chosen)} packets from {log} in "
               f"{time.monotonic() - t0:.2f} s")
    if sent < len(chosen):
        raise typer.Exit(code=1)


@app.command()
def drive(
    vehicle: Annotated[Path, typer.Option(help="Vehicle YAML (docs/drivers.md).")],
    duration: Annotated[float | None, typer.Option(help="Stop after this many seconds "
                                                   "(default: until Ctrl-C).")] = None,
    cmd: Annotated[str | None, typer.Option(help="Send this constant command 'vx,wz' "
                                            "(bring-up test; default: none -- the vehicle "
                                            "gets zero).")] = None,
) -> None:
    """Run a vehicle driver on real hardware (wall clock): /cmd_vel in, odometry, IMU,
    GNSS and status out; prints the link status every second."""
    from navstack.core.msgs import DiagnosticStatus, Twist
    from navstack.drivers.config import load_vehicle
    from navstack.nodes.vehicle_driver import VehicleDriverNode
    from navstack.runtime.node import Runtime
    from navstack.runtime.scheduler import Scheduler

    command = parse_cmd(cmd) if cmd is not None else None
    try:
        config = load_vehicle(vehicle)
        rt = Runtime(Scheduler(mode="wall"))
        driver = VehicleDriverNode(rt, config)
        rt.bring_up()
    except NavstackError as exc:
        raise fail(str(exc)) from None
    if command is not None:
        pub = rt.bus.publisher(config.command.topic, Twist)
        rt.scheduler.create_timer(0.1, lambda: pub.publish(Twist.planar(command[0], 0.0,
                                                                        command[1])))
    rt.bus.subscribe("/vehicle/status", DiagnosticStatus,
                     lambda s: typer.echo(f"[{s.level}] {s.message}  "
                                          f"sent {s.value('commands_sent')}"))
    t_end = rt.now + duration if duration is not None else math.inf
    try:
        rt.scheduler.run_until(t_end)
    except KeyboardInterrupt:
        pass
    finally:
        rt.shut_down()
    typer.echo(f"driver stopped: {driver.commands_sent} commands sent, link losses "
               f"{driver.watchdog.losses}")
