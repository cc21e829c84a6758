"""HTTPS for the page off loopback: the token that lets a person teach, and everything the page
sends, must not cross a network in clear.

    context, fingerprint = server_tls(host, cert=None, key=None)

With a certificate and key (PEM files, `--tls-cert` / `--tls-key`) the page is served with them. Without,
a self-signed certificate is made for this run (key kept in memory and a private temporary folder,
removed at once): the browser warns once, and the person checks the SHA-256 fingerprint printed at start
against the one it shows.
"""
from __future__ import annotations

import hashlib
import ipaddress
import socket
import ssl
import tempfile
from pathlib import Path

from services.certificates import certificate, key_pem, write_private


class TlsError(ValueError):
    """A certificate or key that cannot serve the page; the message names the flag."""


def server_tls(host: str, cert: Path | None = None, key: Path | None = None) -> tuple[ssl.SSLContext, str]:
    """A server context (TLS 1.2 or newer) and the SHA-256 fingerprint of its certificate."""
    if cert is None and key is None:
        cert_pem, key_pem = _self_signed(host)
    else:
        cert_pem, key_pem = _read(cert, "--tls-cert"), _read(key, "--tls-key")
    context = ssl.SSLContext(ssl.PROTOCOL_TLS_SERVER)
    context.minimum_version = ssl.TLSVersion.TLSv1_2
    with tempfile.TemporaryDirectory() as folder:  # load_cert_chain reads files: a 0700 folder, removed at once
        cert_path, key_path = Path(folder) / "cert.pem", Path(folder) / "key.pem"
        cert_path.write_bytes(cert_pem)
        write_private(key_path, key_pem)
        try:
            context.load_cert_chain(cert_path, key_path)
        except ssl.SSLError as err:
            raise TlsError(f"--tls-cert and --tls-key do not make a certificate chain: {err.reason or err}") from None
    return context, fingerprint(cert_pem)


def fingerprint(cert_pem: bytes) -> str:
    """SHA-256 of the certificate's DER bytes, as browsers show it (AB:CD:...)."""
    try:
        der = ssl.PEM_cert_to_DER_cert(cert_pem.decode("ascii"))
    except (ValueError, UnicodeDecodeError):
        raise TlsError("--tls-cert holds no PEM certificate") from None
    return ":".join(f"{b:02X}" for b in hashlib.sha256(der).digest())


def _read(path: Path | None, flag: str) -> bytes:
    if path is None:
        raise TlsError(f"{flag} is needed too: a certificate and its key go together")
    try:
        data = Path(path).read_bytes()
    except OSError as err:
        raise TlsError(f"{flag} {path}: {err.strerror or err}") from None
    if len(data) > 1_000_000:
        raise TlsError(f"{flag} {path}: {len(data)} bytes is no PEM certificate or key")
    return data


def _self_signed(host: str) -> tuple[bytes, bytes]:
    """A certificate for this run, valid for the served host, this machine's name and loopback."""
    from cryptography import x509
    from cryptography.hazmat.primitives import serialization
    from cryptography.hazmat.primitives.asymmetric import ec
    from cryptography.x509.oid import ExtendedKeyUsageOID

    names = {"localhost", socket.gethostname()}
    addresses = {ipaddress.ip_address("127.0.0.1")}
    try:
        address = ipaddress.ip_address(host)
        if not address.is_unspecified:  # 0.0.0.0 is no address a browser opens
            addresses.add(address)
    except ValueError:
        names.add(host)
    key = ec.generate_private_key(ec.SECP256R1())
    cert = certificate(f"dogged ui on {socket.gethostname()}", key, 30, [
        (x509.SubjectAlternativeName([x509.DNSName(n) for n in sorted(names)]
                                     + [x509.IPAddress(a) for a in sorted(addresses)]), False),
        (x509.ExtendedKeyUsage([ExtendedKeyUsageOID.SERVER_AUTH]), False),
        (x509.BasicConstraints(ca=False, path_length=None), True)])
    return cert.public_bytes(serialization.Encoding.PEM), key_pem(key)
