"""Golden table of the rover VCU command string (compat and corrected arithmetic)."""

from __future__ import annotations

import math

import pytest

from navstack.drivers.errors import EncodeError, MalformedPacket
from navstack.drivers.rover_vcu import (
    VcuCommand,
    decode_vcu_command,
    encode_vcu_command,
)

# (linear_x, angular_z, mode, compat string, corrected string)
GOLDEN = [
    (0.123, 0.45, "auto", "104510123001", "104510123001"),  # the documented example
    (0.0, 0.0, "auto", "000000000001", "000000000001"),
    (0.0, 0.29, "auto", "102800000001", "102900000001"),  # the rover's truncation
    (0.0, -0.29, "auto", "002800000001", "002900000001"),
    (0.29, 0.0, "teleop", "000010290100", "000010290100"),
    (-0.123, -0.45, "success", "004500123010", "004500123010"),
    (1.5, 0.0, "auto", "000011500001", "000011500001"),
    (-1.5, 0.0, "auto", "000001500001", "000001500001"),
    (0.0, 1.0, "auto", "110000000001", "110000000001"),
    (0.0, -1.0, "teleop", "010000000100", "010000000100"),
    (0.001, 0.01, "auto", "100110001001", "100110001001"),  # one quantum
    (-0.001, -0.01, "auto", "000100001001", "000100001001"),
    (0.0004, 0.004, "auto", "100010000001", "100010000001"),  # below a quantum: 0, sign kept
    (0.0005, 0.005, "auto", "100110001001", "100110001001"),
    (-0.0004, -0.004, "auto", "000000000001", "000000000001"),
    (0.125, 0.125, "auto", "101210125001", "101310125001"),  # round() halves to even
    (0.135, 0.135, "auto", "101410135001", "101410135001"),
    (0.57, 0.57, "auto", "105610570001", "105710570001"),  # 0.57 * 100 = 56.99...
    (0.58, 0.58, "auto", "105710580001", "105810580001"),
    (1.13, 1.13, "auto", "111211130001", "111311130001"),
    (2.675, 2.675, "auto", "126712675001", "126812675001"),
    (0.1234, 0.1234, "auto", "101210123001", "101210123001"),
    (0.9999, 9.99, "auto", "199911000001", "199911000001"),  # largest yaw
    (9.999, -9.99, "auto", "099919999001", "099919999001"),  # largest speed
    (10.0, 10.0, "auto", "199919999001", "199919999001"),  # saturates, stays 12 chars
    (-12.5, -15.0, "teleop", "099909999100", "099909999100"),
    (0.07, 0.07, "success", "100710070010", "100710070010"),
    (0.14, 0.14, "auto", "101410140001", "101410140001"),
    (0.28, 0.28, "auto", "102810280001", "102810280001"),
    (1.005, 1.005, "auto", "110011004001", "110011005001"),  # 1.005 * 1000 = 1004.99...
    (0.3, -0.3, "auto", "003010300001", "003010300001"),
    (0.5, 0.5, "auto", "105010500001", "105010500001"),
    (-0.0, -0.0, "auto", "000000000001", "000000000001"),
    (1e-9, -1e-9, "auto", "000010000001", "000010000001"),
    (0.0015, 0.015, "auto", "100110002001", "100210002001"),
    (0.0025, 0.025, "auto", "100310003001", "100310003001"),
]


@pytest.mark.parametrize(("vx", "wz", "mode", "compat", "corrected"), GOLDEN)
def test_golden_table(vx: float, wz: float, mode: str, compat: str, corrected: str) -> None:
    assert encode_vcu_command(vx, wz, mode, compat=True) == compat.encode()  # type: ignore[arg-type]
    assert encode_vcu_command(vx, wz, mode) == corrected.encode()  # type: ignore[arg-type]


def test_table_is_large_enough_and_documented_examples_hold() -> None:
    assert len(GOLDEN) >= 30
    assert encode_vcu_command(0.0, 0.45)[1:4] == b"045"
    assert encode_vcu_command(0.123, 0.0)[5:9] == b"0123"
    assert encode_vcu_command(0.0, 0.29, compat=True)[1:4] == b"028"
    assert encode_vcu_command(0.0, 0.29)[1:4] == b"029"
    assert {encode_vcu_command(0, 0, m)[9:] for m in ("teleop", "auto", "success")} == \
        {b"100", b"001", b"010"}


@pytest.mark.parametrize(("vx", "wz", "mode", "compat", "corrected"), GOLDEN)
def test_decode_encode_round_trip_within_quantisation(vx: float, wz: float, mode: str,
                                                      compat: str, corrected: str) -> None:
    for text, slack in ((corrected, 0.5), (compat, 1.0)):
        cmd = decode_vcu_command(text.encode())
        assert cmd.mode == mode
        vx_c, wz_c = max(-9.999, min(9.999, vx)), max(-9.99, min(9.99, wz))
        assert abs(cmd.linear_x - vx_c) <= slack * 0.001 + 1e-12
        assert abs(cmd.angular_z - wz_c) <= slack * 0.01 + 1e-12


def test_decode_values() -> None:
    assert decode_vcu_command(b"104510123001") == VcuCommand(0.123, 0.45, "auto")
    assert decode_vcu_command(b"004500123100") == VcuCommand(-0.123, -0.45, "teleop")


@pytest.mark.parametrize(("data", "reason"), [
    (b"10451012300", "expected 12 bytes, got 11"),
    (b"1045101230011", "expected 12 bytes, got 13"),
    (b"", "expected 12 bytes, got 0"),
    (b"1045a0123001", "non-digit"),
    (b"2045101230 1", "non-digit"),
    (b"204510123001", "direction digits must be 0 or 1"),
    (b"104590123001", "direction digits must be 0 or 1"),
    (b"104510123000", "unknown LED code '000'"),
    (b"104510123111", "unknown LED code '111'"),
    (b"\xff\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00", "non-digit"),
])
def test_decode_rejects(data: bytes, reason: str) -> None:
    with pytest.raises(MalformedPacket, match=reason) as info:
        decode_vcu_command(data)
    assert info.value.codec == "rover VCU command"


@pytest.mark.parametrize(("vx", "wz"), [(math.nan, 0.0), (0.0, math.inf), (-math.inf, 1.0)])
def test_encode_refuses_non_finite(vx: float, wz: float) -> None:
    with pytest.raises(EncodeError, match="must be finite"):
        encode_vcu_command(vx, wz)


def test_encode_refuses_unknown_mode() -> None:
    with pytest.raises(EncodeError, match="unknown mode 'manual'"):
        encode_vcu_command(0.1, 0.1, "manual")  # type: ignore[arg-type]
