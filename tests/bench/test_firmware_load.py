"""The upload benchmark's files (bench/firmware_load.py): a release-sized image with the release's
checksum (docs/FIRMWARE-BEHAVIOUR.md#fb-image-checksum: R7 495305442) and a signature the bootloader's
check accepts (ECDSA P-256 over the image's SHA-256, r then s, 32 bytes each, #fb-bootloader)."""
from __future__ import annotations

import pathlib

from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.hazmat.primitives.asymmetric.utils import encode_dss_signature

from buildhat_conformance.bench.firmware_load import release_sized_files


def _checksum(data: bytes) -> int:
    """fb-image-checksum, written out here: s = 1; per byte shift left one (mod 2^32), XOR 0x1D872B41 if
    a 1 was shifted out, XOR the byte."""
    s = 1
    for b in data:
        s = ((s << 1) & 0xFFFFFFFF) ^ (0x1D872B41 if s >> 31 else 0) ^ b
    return s


def test_the_image_has_r7s_size_and_checksum_and_a_signature_that_verifies(tmp_path: pathlib.Path):
    img, sig, pem = (pathlib.Path(p) for p in release_sized_files(str(tmp_path), "R7"))
    image, signature = img.read_bytes(), sig.read_bytes()
    assert len(image) == 51456 and _checksum(image) == 495305442
    assert len(signature) == 64
    key = serialization.load_pem_public_key(pem.read_bytes())
    assert isinstance(key, ec.EllipticCurvePublicKey) and key.curve.name == "secp256r1"
    der = encode_dss_signature(int.from_bytes(signature[:32], "big"), int.from_bytes(signature[32:], "big"))
    key.verify(der, image, ec.ECDSA(hashes.SHA256()))          # raises InvalidSignature if not
