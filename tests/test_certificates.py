"""`dogged certs` (issue 30): private keys are 0600 from their first byte, the CA's key never sits in
the services' directory, each identity's key is alone in its folder, and the router role is the
router's own."""
import os
import stat
from pathlib import Path

import pytest

from services.certificates import make_certs
from services.security import identities_in, tls_section
from services.supervisor.commands import certs

IDENTITIES = ["router.router", "platform.aibo", "operator.bob"]


def mode(path: Path) -> int:
    return stat.S_IMODE(path.stat().st_mode)


def test_keys_are_private_from_their_first_byte(tmp_path, monkeypatch):
    """With nothing narrowing them afterwards and a umask of 0, every key is still 0600: the mode a key
    is created with is the one it keeps, so no one can open it between its writing and a chmod."""
    narrowed = []
    monkeypatch.setattr(os, "chmod", lambda path, *a, **k: narrowed.append(str(path)))
    monkeypatch.setattr(Path, "chmod", lambda self, *a, **k: narrowed.append(str(self)))
    before = os.umask(0)
    try:
        make_certs(tmp_path / "certs", IDENTITIES)
    finally:
        os.umask(before)
    keys = sorted(tmp_path.rglob("*.key"))
    assert len(keys) == len(IDENTITIES) + 1  # and the CA's
    assert {str(k.relative_to(tmp_path)): oct(mode(k)) for k in keys} == {
        str(k.relative_to(tmp_path)): "0o600" for k in keys}
    folders = [tmp_path / "certs" / cn for cn in IDENTITIES] + [tmp_path / "certs-ca"]
    assert {f.name: oct(mode(f)) for f in folders} == {f.name: "0o700" for f in folders}


def test_the_ca_key_is_not_in_the_services_directory_and_each_key_is_alone(tmp_path):
    directory = tmp_path / "certs"
    make_certs(directory, IDENTITIES)
    assert list(directory.rglob("ca.key")) == [] and (tmp_path / "certs-ca" / "ca.key").is_file()
    assert identities_in(directory) == sorted(IDENTITIES)
    for cn in IDENTITIES:  # a service is handed its folder: no other identity's key is in it
        folder = Path(tls_section(directory, cn)["listen_private_key"]).parent
        assert folder == directory / cn
        assert sorted(p.name for p in folder.iterdir()) == ["ca.pem", f"{cn}.key", f"{cn}.pem"]
        assert tls_section(folder, cn) == tls_section(directory, cn)  # the folder alone is enough


def test_an_identity_made_again_is_kept_and_later_ones_share_the_ca(tmp_path):
    directory = tmp_path / "certs"
    make_certs(directory, ["operator.bob"])
    key = (directory / "operator.bob" / "operator.bob.key").read_bytes()
    assert [p.name for p in make_certs(directory, ["operator.bob", "teacher.eve"])] == ["teacher.eve.pem"]
    assert (directory / "operator.bob" / "operator.bob.key").read_bytes() == key
    assert (directory / "teacher.eve" / "ca.pem").read_bytes() == (directory / "ca.pem").read_bytes()


def test_the_layout_with_the_ca_key_beside_the_certificates_is_refused(tmp_path):
    directory = tmp_path / "certs"
    directory.mkdir()
    (directory / "ca.key").write_text("an old layout's CA key")
    with pytest.raises(ValueError, match="the CA's key sits in the services' directory.*move it out"):
        make_certs(directory, ["operator.bob"])
    with pytest.raises(ValueError, match="must lie outside"):
        make_certs(tmp_path / "other", ["operator.bob"], ca_dir=tmp_path / "other" / "ca")


def test_dogged_certs_makes_no_router_but_the_routers_own(tmp_path, capsys):
    assert certs(str(tmp_path / "certs"), None, ["router.eve"]) == 2
    assert "the router role is the router's own, router.router, only" in capsys.readouterr().err
    assert not (tmp_path / "certs").exists()
    assert certs(str(tmp_path / "certs"), None, ["router.router", "teacher.eve"], ca=str(tmp_path / "ca")) == 0
    out = capsys.readouterr().out
    assert "2 certificates" in out and "restart it" in out and (tmp_path / "ca" / "ca.key").is_file()
