"""rosauth MAC computation and verification."""

import hashlib

import pytest

from hitrobot_server.protocol.auth import compute_mac, load_secret, verify

SECRET = "1234567890abcdef"
T = 1_700_000_000
END = T + 3600


def auth_op(**changes):
    op = {
        "op": "auth",
        "mac": compute_mac(SECRET, "192.168.1.101", "192.168.1.111", "r4nd", T, "admin", END),
        "client": "192.168.1.101",
        "dest": "192.168.1.111",
        "rand": "r4nd",
        "t": T,
        "level": "admin",
        "end": END,
    }
    op.update(changes)
    return op


def test_mac_is_sha512_of_fields_in_rosauth_order():
    # secret + client + dest + rand + t (integer seconds) + level + end (integer seconds)
    text = (
        "1234567890abcdef"
        + "192.168.1.101"
        + "192.168.1.111"
        + "r4nd"
        + "1700000000"
        + "admin"
        + "1700003600"
    )
    expected = hashlib.sha512(text.encode()).hexdigest()
    mac = compute_mac(SECRET, "192.168.1.101", "192.168.1.111", "r4nd", T, "admin", END)
    assert mac == expected
    assert len(expected) == 128 and expected == expected.lower()


def test_mac_uses_whole_seconds_of_float_times():
    assert compute_mac(SECRET, "c", "d", "r", T + 0.9, "l", END + 0.2) == compute_mac(
        SECRET, "c", "d", "r", T, "l", END
    )


def test_valid_request_is_accepted():
    assert verify(auth_op(), SECRET, now=T + 1.0)
    assert verify(auth_op(), SECRET, now=T - 4.5)  # client clock slightly ahead


def test_float_times_are_accepted():
    assert verify(auth_op(t=T + 0.75, end=END + 0.5), SECRET, now=T + 2.0)


def test_request_older_than_allowed_delta_is_rejected():
    assert not verify(auth_op(), SECRET, now=T + 5.0)
    assert verify(auth_op(), SECRET, now=T + 30.0, allowed_delta=60.0)


def test_request_from_the_future_is_rejected():
    assert not verify(auth_op(), SECRET, now=T - 10.0)


def test_expired_session_is_rejected():
    op = auth_op(t=END - 1)
    op["mac"] = compute_mac(SECRET, op["client"], op["dest"], op["rand"], END - 1, "admin", END)
    assert verify(op, SECRET, now=END - 1.5)
    assert not verify(op, SECRET, now=END)


def test_uppercase_mac_is_rejected():
    op = auth_op()
    assert not verify(auth_op(mac=op["mac"].upper()), SECRET, now=T)


def test_truncated_mac_is_rejected():
    assert not verify(auth_op(mac=auth_op()["mac"][:64]), SECRET, now=T)


@pytest.mark.parametrize(
    "change", [{"level": "user"}, {"client": "10.0.0.1"}, {"rand": "other"}, {"dest": "x"}]
)
def test_any_changed_field_breaks_the_mac(change):
    assert not verify(auth_op(**change), SECRET, now=T)


def test_wrong_secret_is_rejected():
    assert not verify(auth_op(), "fedcba0987654321", now=T)


def test_load_secret_reads_first_line(tmp_path):
    path = tmp_path / "secret"
    path.write_text("  1234567890abcdef \nsecond line\n")
    assert load_secret(path) == SECRET
    assert load_secret(str(path)) == SECRET


@pytest.mark.parametrize("content", ["short\n", "1234567890abcdefg\n", "", "\n1234567890abcdef\n"])
def test_load_secret_requires_sixteen_characters(tmp_path, content):
    path = tmp_path / "secret"
    path.write_text(content)
    with pytest.raises(ValueError, match="exactly 16 characters"):
        load_secret(path)


def test_replay_cache_accepts_each_mac_once_and_forgets_it_after_the_window():
    from hitrobot_server.protocol.auth import ReplayCache

    cache = ReplayCache(allowed_delta=5.0)
    assert cache.use("m1", 100.0, 100.2)
    assert not cache.use("m1", 100.0, 101.0)
    assert cache.use("m2", 101.0, 101.0)
    assert len(cache) == 2
    # once t + window is past, verify() refuses the op anyway: the entry is dropped
    assert cache.use("m3", 106.0, 106.0) and len(cache) == 1


@pytest.mark.parametrize("field", ["t", "end"])
@pytest.mark.parametrize("value", [float("nan"), float("inf"), float("-inf")])
def test_non_finite_times_are_refused_not_an_exception(field, value):
    assert not verify({**auth_op(), field: value}, SECRET, now=T + 1.0)
