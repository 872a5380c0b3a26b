"""The JSON Schemas in protocol/schemas agree with OPS and with what the server emits."""

import json
from pathlib import Path

import orjson
import pytest

from hitrobot_server.protocol import png
from hitrobot_server.protocol.errors import ProtocolError
from hitrobot_server.protocol.fragment import FragmentIds, fragment
from hitrobot_server.protocol.ops import OPS, validate_op

SCHEMAS = Path(__file__).resolve().parents[2] / "protocol" / "schemas"
S2C = {
    "publish",
    "service_response",
    "call_service",
    "status",
    "fragment",
    "png",
    "action_feedback",
    "action_result",
    "send_action_goal",
    "cancel_action_goal",
}


def load(name: str) -> dict:
    return json.loads((SCHEMAS / name).read_text(encoding="utf-8"))


def c2s_names() -> set[str]:
    return {p.name.removesuffix(".schema.json") for p in SCHEMAS.glob("*.schema.json")} - {
        p.name.removesuffix(".schema.json") for p in SCHEMAS.glob("*.s2c.schema.json")
    }


def all_schemas() -> list[str]:
    return sorted(p.name for p in SCHEMAS.glob("*.schema.json"))


def test_one_client_schema_per_op():
    assert c2s_names() == set(OPS)


def test_server_to_client_schemas_exist():
    names = {p.name.removesuffix(".s2c.schema.json") for p in SCHEMAS.glob("*.s2c.schema.json")}
    assert names == S2C


@pytest.mark.parametrize("op", sorted(OPS))
def test_client_schema_agrees_with_spec(op):
    schema = load(f"{op}.schema.json")
    spec = OPS[op]
    assert schema["properties"]["op"] == {"const": op}
    assert schema["required"] == ["op", *spec.required]
    properties = {k: v for k, v in schema["properties"].items() if k != "op"}
    assert list(properties) == list(spec.names)
    for field in spec.fields:
        prop = properties[field.name]
        declared = prop.get("type", [])
        assert tuple([declared] if isinstance(declared, str) else declared) == field.types
        assert tuple(prop.get("enum", ())) == field.enum
        assert prop.get("minimum") == field.minimum
        assert prop["description"]


@pytest.mark.parametrize("name", all_schemas())
def test_schema_is_documented_and_has_examples(name):
    schema = load(name)
    assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    assert schema["title"] and schema["description"]
    assert schema["examples"]
    op = schema["properties"]["op"]["const"]
    assert all(example["op"] == op for example in schema["examples"])


@pytest.mark.parametrize("op", sorted(OPS))
def test_client_examples_pass_the_validator(op):
    for example in load(f"{op}.schema.json")["examples"]:
        value = validate_op(example)
        assert type(value) is OPS[op].cls
        assert all(getattr(value, k) == v for k, v in example.items() if k != "op")


def test_png_example_decodes_to_json():
    for name in ("png.schema.json", "png.s2c.schema.json"):
        data = load(name)["examples"][0]["data"]
        assert orjson.loads(png.decode(data))["op"] == "publish"


# --- checks with a JSON Schema validator ---------------------------------------------------


@pytest.fixture(scope="module")
def validator():
    jsonschema = pytest.importorskip("jsonschema")

    def make(name):
        schema = load(name)
        jsonschema.Draft202012Validator.check_schema(schema)
        return jsonschema.Draft202012Validator(schema)

    return make


@pytest.mark.parametrize("name", all_schemas())
def test_examples_validate(validator, name):
    checker = validator(name)
    for example in load(name)["examples"]:
        assert not list(checker.iter_errors(example))


@pytest.mark.parametrize("op", sorted(OPS))
def test_schema_rejects_what_the_validator_rejects(validator, op):
    checker = validator(f"{op}.schema.json")
    example = load(f"{op}.schema.json")["examples"][0]
    for field in OPS[op].required:
        broken = {k: v for k, v in example.items() if k != field}
        assert not checker.is_valid(broken)
        with pytest.raises(ProtocolError):
            validate_op(broken)
    for field in OPS[op].fields:
        if field.types and "object" not in field.types:
            broken = {**example, field.name: {"wrong": "type"}}
            assert not checker.is_valid(broken)
            with pytest.raises(ProtocolError):
                validate_op(broken)


def test_server_outputs_match_their_schemas(validator):
    status = validator("status.s2c.schema.json")
    error = ProtocolError("publish: missing required field 'topic'", "p1")
    assert status.is_valid(error.to_status())
    assert status.is_valid(ProtocolError("unknown op 'x'").to_status())

    frag = validator("fragment.s2c.schema.json")
    payload = orjson.dumps({"op": "publish", "topic": "/a", "msg": {"data": "x" * 50}}).decode()
    for op in fragment(payload, 16, FragmentIds().next()):
        assert not list(frag.iter_errors(op))

    assert validator("png.s2c.schema.json").is_valid(orjson.loads(png.png_op(payload.encode())))
