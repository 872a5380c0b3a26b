"""``mqtts://`` through mosquitto with TLS: the broker's certificate checked against
``--vda5050-ca-file``, a client certificate (``--vda5050-cert-file`` / ``--vda5050-key-file``)
and a user and password (the password from ``--vda5050-password-file``); a wrong password
leaves the link down with the broker's reason, and the server serves on."""

from __future__ import annotations

import asyncio
import datetime
import ipaddress
import ssl
import subprocess

import aiomqtt
import orjson
from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import NameOID

from tests.helpers import WsClient, round_trip, until
from tests.vda5050.conftest import Broker


def issue(name: str, folder, ca=None, server: bool = False):
    key = ec.generate_private_key(ec.SECP256R1())
    subject = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, name)])
    now = datetime.datetime.now(datetime.UTC)
    builder = (x509.CertificateBuilder().subject_name(subject)
               .issuer_name(ca[1].subject if ca else subject).public_key(key.public_key())
               .serial_number(x509.random_serial_number())
               .not_valid_before(now - datetime.timedelta(minutes=5))
               .not_valid_after(now + datetime.timedelta(days=1))
               .add_extension(x509.BasicConstraints(ca=ca is None, path_length=None), True))
    if server:
        builder = builder.add_extension(x509.SubjectAlternativeName(
            [x509.IPAddress(ipaddress.ip_address("127.0.0.1"))]), False)
    cert = builder.sign(ca[0] if ca else key, hashes.SHA256())
    (folder / f"{name}.pem").write_bytes(cert.public_bytes(serialization.Encoding.PEM))
    (folder / f"{name}.key").write_bytes(key.private_bytes(
        serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
        serialization.NoEncryption()))
    return key, cert


def tls_broker(folder) -> Broker:
    ca = issue("ca", folder)
    issue("broker", folder, ca, server=True)
    issue("client", folder, ca)
    subprocess.run(["mosquitto_passwd", "-b", "-c", str(folder / "passwd"), "robot", "s3cret"],
                   check=True, capture_output=True, timeout=30)
    return Broker(folder, anonymous=False, extra=(
        f"cafile {folder / 'ca.pem'}\ncertfile {folder / 'broker.pem'}\n"
        f"keyfile {folder / 'broker.key'}\nrequire_certificate true\n"
        f"password_file {folder / 'passwd'}\n"))


async def test_mqtts_with_a_client_certificate_and_a_password(make_server, tmp_path):
    broker = tls_broker(tmp_path)
    try:
        (tmp_path / "password").write_text("s3cret\n")
        files = {"vda5050_ca_file": str(tmp_path / "ca.pem"),
                 "vda5050_cert_file": str(tmp_path / "client.pem"),
                 "vda5050_key_file": str(tmp_path / "client.key")}
        server = await make_server(robot="sim", vda5050=f"mqtts://robot@127.0.0.1:{broker.port}",
                                   vda5050_password_file=str(tmp_path / "password"), **files)
        link = server.vda5050.links[0][1]
        await until(lambda: link.connected, "the link up over TLS", 15)
        context = ssl.create_default_context(cafile=str(tmp_path / "ca.pem"))
        context.load_cert_chain(str(tmp_path / "client.pem"), str(tmp_path / "client.key"))
        async with aiomqtt.Client("127.0.0.1", broker.port, username="robot",
                                  password="s3cret", tls_context=context) as master:
            await master.subscribe("uagv/v2/hitrobot/robot/connection")
            async for message in master.messages:
                assert orjson.loads(message.payload)["connectionState"] == "ONLINE"
                break

        wrong = tmp_path / "wrong"
        wrong.write_text("guess\n")
        other = await make_server(robot="none", vda5050=f"mqtts://robot@127.0.0.1:{broker.port}",
                                  vda5050_password_file=str(wrong), **files)
        assert other.vda5050 is None  # no robot, no vehicle: nothing to link
        refused = await make_server(robot="sim", vda5050=f"mqtts://robot@127.0.0.1:"
                                    f"{broker.port}", vda5050_password_file=str(wrong), **files)
        bad = refused.vda5050.links[0][1]
        await until(lambda: bad.last_error, "the broker's refusal", 15)
        assert not bad.connected and "authori" in bad.last_error.lower(), bad.last_error
        client = await WsClient.open(refused.port)
        try:
            await round_trip(client)  # the server serves on
        finally:
            await client.close()
        await asyncio.sleep(0)
    finally:
        broker.stop()
