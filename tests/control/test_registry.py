"""dcmppi.control.registry: entries by name, one message for an unknown name, built-ins loaded
on the first lookup."""

import sys

import pytest

from dcmppi.control.agents import Agent
from dcmppi.control.agents.base import AGENTS
from dcmppi.control.planners.registry import CONTROLLERS
from dcmppi.control.predictors.base import PREDICTORS
from dcmppi.control.registry import Registry
from dcmppi.tasks.pedestrians import walkers


def test_names_are_sorted_whatever_the_order_of_registration():
    registry = Registry("colour")
    for name in ("red", "green", "blue"):
        registry.register(name)(type(name.title(), (), {}))
    assert registry.names() == ["blue", "green", "red"]
    assert "green" in registry and "grey" not in registry
    assert registry.get("red").__name__ == "Red" and registry.get("red").name == "red"


def test_an_unknown_name_is_one_line_naming_it_the_kind_and_the_known_names():
    registry = Registry("colour", hint="or #rrggbb")
    registry.register("red")(object())
    registry.register("blue")(object())
    with pytest.raises(ValueError) as caught:
        registry.get("grey")
    assert str(caught.value) == "unknown colour 'grey'; valid names: blue, red, or #rrggbb"


@pytest.mark.parametrize(
    "registry, kind",
    [
        (CONTROLLERS, "controller"),
        (AGENTS, "agent"),
        (PREDICTORS, "predictor"),
        (walkers.BEHAVIOR, "pedestrian behaviour"),
    ],
)
def test_every_registry_names_its_kind_and_its_entries(registry, kind):
    with pytest.raises(ValueError, match=f"^unknown {kind} 'nothing'; valid names: ") as caught:
        registry.get("nothing")
    assert ", ".join(registry.names()) in str(caught.value)
    assert "\n" not in str(caught.value)


def test_a_taken_name_refuses_another_entry_and_takes_the_same_definition_again():
    registry = Registry("colour")

    def define():
        class Red:
            pass

        return Red

    first = registry.register("red")(define())
    again = registry.register("red")(define())  # the same class statement run again
    assert again is not first and registry.get("red") is again
    registry.register("red")(again)
    with pytest.raises(ValueError, match="colour 'red' is registered already"):
        registry.register("red")(type("Crimson", (), {}))
    with pytest.raises(ValueError, match="colour 'blue' is registered already"):
        registry.register("blue")(object())
        registry.register("blue")(object())
    registry.unregister("red")
    registry.register("red")(type("Crimson", (), {}))
    assert registry.get("red").__name__ == "Crimson"


def test_a_built_in_agent_name_refuses_a_new_class():
    with pytest.raises(ValueError, match="agent 'dubins' is registered already"):

        @AGENTS.register("dubins")
        class Dubins(Agent):
            pass

    assert AGENTS.get("dubins").__module__ == "dcmppi.control.agents.dubins"


def test_a_base_class_is_enforced():
    registry = Registry("agent", base=Agent)
    with pytest.raises(TypeError, match="agent 'thing' must be a subclass of Agent; got <class"):
        registry.register("thing")(dict)
    assert registry.names() == []


def test_built_ins_load_on_the_first_lookup(tmp_path, monkeypatch):
    (tmp_path / "colours_builtin.py").write_text(
        "from colours_registry import COLOURS\n\n@COLOURS.register('red')\nclass Red:\n    pass\n"
    )
    (tmp_path / "colours_registry.py").write_text(
        "from dcmppi.control.registry import Registry\n\n"
        "COLOURS = Registry('colour', builtins=['colours_builtin'])\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    try:
        from colours_registry import COLOURS

        assert "colours_builtin" not in sys.modules
        assert COLOURS.names() == ["red"]
        assert "colours_builtin" in sys.modules
    finally:
        for name in ("colours_builtin", "colours_registry"):
            sys.modules.pop(name, None)
