import pytest

from avtrack.registry import Registry


def test_register_sets_name_and_refuses_another_object_under_a_taken_name():
    reg: Registry[type] = Registry("widget")

    @reg.register("a")
    class A:
        pass

    assert reg == {"a": A} and A.name == "a"
    assert reg.register("a")(A) is A
    with pytest.raises(ValueError, match="widget 'a' is already registered"):
        reg.register("a")(type("B", (), {}))
    with pytest.raises(ValueError, match="unknown widget 'b' \\(known: a\\)"):
        reg.get_or_raise("b")
    with pytest.raises(TypeError, match="name must be a non-empty str"):
        reg.register("")


def test_functions_register_without_a_name_attribute():
    reg: Registry = Registry("task")
    fn = reg.register("f")(len)
    assert fn is len and reg["f"] is len
