"""`dogged certs`: a deployment's CA and one folder per identity (issue 12; laid out for issue 30).

    certs/                  the deployment's directory (a profile's zenoh.security)
      ca.pem                the CA's certificate, public
      platform.aibo/        one folder per identity (0700), all a process showing it needs:
        platform.aibo.key     its private key (0600 from its first byte)
        platform.aibo.pem     its certificate
        ca.pem                the CA's certificate
    certs-ca/               the CA (0700), outside the services' directory: ca.key (0600), ca.pem

A service is handed its own folder only, and the CA's key, which would let any process holding it mint
any identity, never sits beside the services' certificates: `dogged certs` signs from the CA directory
(`--ca`, by default the deployment directory's sibling `<name>-ca`).
"""
from __future__ import annotations

import datetime
import ipaddress
import os
from pathlib import Path

from services.security import role_of

CA_KEY, CA_CERT = "ca.key", "ca.pem"


def default_ca_dir(directory: Path) -> Path:
    """Where the CA of a deployment directory lives unless told: beside it, never in it."""
    directory = Path(directory).absolute()
    return directory.parent / f"{directory.name}-ca"


def certificate(cn: str, key, valid_days: int, extensions, issuer=None):
    """An X.509 certificate for `key`, named `cn`, signed by `issuer` = (its name, its key), or by
    itself; valid from five minutes ago (clocks differ) for `valid_days`."""
    from cryptography import x509
    from cryptography.hazmat.primitives import hashes
    from cryptography.x509.oid import NameOID

    now = datetime.datetime.now(datetime.UTC)
    name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, cn)])
    issuer_name, issuer_key = issuer or (name, key)
    builder = (x509.CertificateBuilder().subject_name(name).issuer_name(issuer_name)
               .public_key(key.public_key()).serial_number(x509.random_serial_number())
               .not_valid_before(now - datetime.timedelta(minutes=5))
               .not_valid_after(now + datetime.timedelta(days=valid_days)))
    for extension, critical in extensions:
        builder = builder.add_extension(extension, critical=critical)
    return builder.sign(issuer_key, hashes.SHA256())


def key_pem(key) -> bytes:
    """A private key as unencrypted PKCS#8 PEM (kept in a 0600 file, or never on disk)."""
    from cryptography.hazmat.primitives import serialization
    return key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
                             serialization.NoEncryption())


def write_private(path: Path, data: bytes) -> None:
    """A new file only its owner reads, 0600 from its creation (never written first and narrowed after,
    whatever the umask); an existing one is never overwritten."""
    fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600)
    with os.fdopen(fd, "wb") as f:
        f.write(data)


def private_folder(path: Path) -> Path:
    """A folder only its owner enters (0700 when made; an existing one is left as it is)."""
    path.mkdir(mode=0o700, parents=True, exist_ok=True)
    return path


def load_or_make_ca(directory: Path, ca_dir: Path, days: int):
    """The CA's (certificate, key): loaded from `ca_dir`, or made there once. ValueError for a CA key in
    the services' directory (the layout before issue 30), or a CA certificate there whose key is elsewhere."""
    from cryptography import x509
    from cryptography.hazmat.primitives import serialization
    from cryptography.hazmat.primitives.asymmetric import ec

    if (directory / CA_KEY).exists():
        raise ValueError(f"{directory / CA_KEY}: the CA's key sits in the services' directory, where one compromised "
                         f"service could mint any identity: move it out (mkdir -m 700 {ca_dir} && mv "
                         f"{directory / CA_KEY} {directory / CA_CERT} {ca_dir}/), remove the old keys and "
                         f"certificates beside it, and run `dogged certs` again")
    if (ca_dir / CA_KEY).exists():
        ca_cert = x509.load_pem_x509_certificate((ca_dir / CA_CERT).read_bytes())
        ca_key = serialization.load_pem_private_key((ca_dir / CA_KEY).read_bytes(), None)
        return ca_cert, ca_key
    if (directory / CA_CERT).exists():
        raise ValueError(f"{directory / CA_CERT} is a CA whose key is not in {ca_dir}: say where it is with --ca")
    ca_key = ec.generate_private_key(ec.SECP256R1())
    ca_cert = certificate("dogged-ca", ca_key, 10 * days, [(x509.BasicConstraints(ca=True, path_length=0), True)])
    private_folder(ca_dir)
    write_private(ca_dir / CA_KEY, key_pem(ca_key))
    (ca_dir / CA_CERT).write_bytes(ca_cert.public_bytes(serialization.Encoding.PEM))
    return ca_cert, ca_key


def make_certs(directory: Path, identities: list[str], days: int = 365, ca_dir: Path | None = None) -> list[Path]:
    """A folder per identity in `directory` (its key, its certificate, the CA's), signed by the CA in
    `ca_dir` (default: default_ca_dir; made once). An identity whose folder holds its certificate is kept.
    Returns the certificates made."""
    from cryptography import x509
    from cryptography.hazmat.primitives import serialization
    from cryptography.hazmat.primitives.asymmetric import ec
    from cryptography.x509.oid import ExtendedKeyUsageOID

    for cn in identities:  # all checked before anything is written
        role_of(cn)
    directory = Path(directory)
    ca_dir = Path(ca_dir) if ca_dir is not None else default_ca_dir(directory)
    if ca_dir.absolute().is_relative_to(directory.absolute()):
        raise ValueError(f"--ca {ca_dir}: the CA's directory must lie outside {directory}, which services are given")
    private_folder(directory)
    ca_cert, ca_key = load_or_make_ca(directory, ca_dir, days)
    ca_pem = ca_cert.public_bytes(serialization.Encoding.PEM)
    if not (directory / CA_CERT).exists():
        (directory / CA_CERT).write_bytes(ca_pem)
    elif (directory / CA_CERT).read_bytes() != ca_pem:
        raise ValueError(f"{directory / CA_CERT} is not the CA in {ca_dir}: say where its CA is with --ca")
    loopback = [x509.DNSName("localhost"), x509.IPAddress(ipaddress.ip_address("127.0.0.1"))]
    leaf = [(x509.SubjectAlternativeName(loopback), False),
            (x509.ExtendedKeyUsage([ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH]), False),
            (x509.BasicConstraints(ca=False, path_length=None), True)]
    written = []
    for cn in identities:
        folder = directory / cn
        if (folder / f"{cn}.pem").exists():
            continue
        key = ec.generate_private_key(ec.SECP256R1())
        cert = certificate(cn, key, days, leaf, issuer=(ca_cert.subject, ca_key))
        try:
            write_private(private_folder(folder) / f"{cn}.key", key_pem(key))
        except FileExistsError:
            raise ValueError(f"{folder / cn}.key exists without its certificate: remove {folder} and run "
                             "again") from None
        (folder / f"{cn}.pem").write_bytes(cert.public_bytes(serialization.Encoding.PEM))
        (folder / CA_CERT).write_bytes(ca_pem)
        written.append(folder / f"{cn}.pem")
    return written
