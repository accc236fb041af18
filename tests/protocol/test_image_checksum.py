"""The bootloader's image checksum (protocol/image_checksum.py) against its algebraic form in
docs/FIRMWARE-BEHAVIOUR.md#fb-image-checksum: s = (x^n + sum b_i(x) x^(n-1-i)) mod P(x), P(x) = x^32 plus
the polynomial of 0x1D872B41, computed here by carry-less polynomial division (not by the shift loop)."""
from __future__ import annotations

import random

import pytest

from buildhat_conformance.protocol.image_checksum import bootloader_checksum, image_with_checksum

P = (1 << 32) | 0x1D872B41
# fb-image-checksum: the release images' checksums.
RELEASES = [2671638670, 3595850782, 3269132858, 2615158163, 2080457803, 139016571, 495305442]


def _mod_p(value: int) -> int:
    """``value`` (a GF(2) polynomial as bits) reduced mod P."""
    while value.bit_length() > 32:
        value ^= P << (value.bit_length() - 33)
    return value


def _by_the_formula(data: bytes) -> int:
    # One shift a byte: the start value 1 ends up times x^n, byte b_i times x^(n-1-i).
    n = len(data)
    total = 1 << n
    for i, b in enumerate(data):
        total ^= b << (n - 1 - i)
    return _mod_p(total)


def test_an_empty_image_gives_1():
    assert bootloader_checksum(b"") == 1


@pytest.mark.parametrize("size", [1, 2, 31, 32, 33, 100, 1000])
def test_the_checksum_is_the_documents_polynomial_remainder(size):
    rng = random.Random(size)
    data = bytes(rng.randrange(256) for _ in range(size))
    assert bootloader_checksum(data) == _by_the_formula(data)


def test_a_checksum_continues_from_a_state():
    assert bootloader_checksum(b"def", bootloader_checksum(b"abc")) == bootloader_checksum(b"abcdef")


@pytest.mark.parametrize("checksum", RELEASES)
def test_an_image_with_a_chosen_checksum_has_it(checksum):
    image = image_with_checksum(4096, checksum)
    assert len(image) == 4096
    assert _by_the_formula(image) == checksum


def test_fewer_than_32_bytes_cannot_reach_any_checksum():
    with pytest.raises(ValueError, match="at least 32 bytes"):
        image_with_checksum(31, RELEASES[0])
