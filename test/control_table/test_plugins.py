"""A family plug-in's checks (``control_table._plugins``): what is refused, and why, before a family
from outside the package joins the tables. The plug-in installed and driven through the node:
test/test_family_plugin.py."""
import dataclasses

import pytest

from dynamixel_handler.control_table import FAMILIES, PROTOCOL1_FAMILIES, X, family_named, known_models, model_by_number
from dynamixel_handler.control_table._plugins import GROUP, Refused, check_family, check_models, installed
from dynamixel_handler.control_table.behaviour import FamilyBehaviour

from support.z_family import NUMBER, PLUGIN, SAME_NUMBER, Z, ZBehaviour

BUILT_IN = FAMILIES + PROTOCOL1_FAMILIES
TAKEN = {m.number for m in known_models()}


def z_models():
    return tuple(PLUGIN.models(model_by_number))


def test_a_well_formed_family_is_taken_with_its_models():
    check_family(Z, BUILT_IN)
    models = z_models()
    check_models(Z, models, TAKEN)
    assert [(m.number, m.family, m.series) for m in models] == [(NUMBER, Z, "Z")]
    assert models[0].items == model_by_number(1020).items  # the XM430's table under its own number
    assert Z.behaviour.common_bits(0x01) == 1 << 5  # its bit 0 is overload, bit 5 of the X layout
    assert Z.behaviour.describe(0x01) == "Z error 0x01"


def test_none_is_installed_here():
    """The test process has no plug-in installed: the tables are the built-in ones."""
    assert installed(BUILT_IN, {2: TAKEN}, model_by_number) == ()
    assert GROUP == "dynamixel_handler.families"
    with pytest.raises(KeyError):
        family_named("Z")


@pytest.mark.parametrize("change, why", [
    ({"name": "x"}, "its name 'x' is the name of family X"),
    ({"title": "pro"}, "its title 'pro' is the title of family PRO"),
    ({"suffix": "y"}, "its suffix 'y' is the suffix of family Y"),
    ({"title": "Z z"}, "its title 'Z z' is not a name"),
    ({"protocol": 3}, "protocol 3 is neither 1 nor 2"),
    ({"modes": frozenset({"position", "torque"})}, "are not among"),
    ({"behaviour": FamilyBehaviour(error_bits=(("stall", 0),))}, "error bits ['stall']"),
    ({"behaviour": object()}, "its behaviour is a object, not a FamilyBehaviour"),
    ({"series_topics": True}, "command topics of its own need messages of their own"),
])
def test_a_family_that_clashes_or_is_malformed_is_refused(change, why):
    with pytest.raises(Refused) as refused:
        check_family(dataclasses.replace(Z, **change), BUILT_IN)
    assert why in str(refused.value)


def test_a_family_commanded_as_a_built_in_one_is_taken():
    check_family(dataclasses.replace(Z, series_topics=True, commanded_as=X), BUILT_IN)
    with pytest.raises(Refused, match="not a ServoFamily"):
        check_family("Z", BUILT_IN)


def test_models_that_are_not_the_family_s_or_whose_numbers_are_taken_are_refused():
    model = z_models()[0]
    cases = [
        ((), "no models"),
        ((model_by_number(1020),), "is not a Model of the family"),
        ((model, model), "model number 9001 is taken"),
        ((dataclasses.replace(model, number=1020),), "model number 1020 is taken"),
    ]
    for models, why in cases:
        with pytest.raises(Refused) as refused:
            check_models(Z, models, TAKEN)
        assert why in str(refused.value)
    odd = dataclasses.replace(Z, dummy_model=1020)
    with pytest.raises(Refused, match="its dummy_model 1020 is none of its models"):
        check_models(odd, (dataclasses.replace(model, family=odd),), TAKEN)
    other = tuple(SAME_NUMBER.models(model_by_number))
    with pytest.raises(Refused, match="model number 1020 is taken"):
        check_models(SAME_NUMBER.family, other, TAKEN)
    assert isinstance(Z.behaviour, ZBehaviour)
