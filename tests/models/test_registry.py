"""The model registry is the catalog's: every name it lists, and a form for exactly the kinds it serves."""

import pytest

from femref.core import catalog
from femref.models import FORMS, REGISTRY, model_form


def test_registry_names_are_the_catalogs_models():
    """Every catalog model is registered except ``ann`` (a network is an estimator, listed under estimators:)."""
    assert set(REGISTRY) == {name for name, entry in catalog.MODELS.items() if entry.kinds}


@pytest.mark.parametrize("name", sorted(REGISTRY))
@pytest.mark.parametrize("kind", catalog.SIMULATED_KINDS)
def test_a_model_has_a_form_for_exactly_the_kinds_it_serves(name, kind):
    """The catalog says whether it serves the kind; the model offers that form (harmonic, transient, car) or not."""
    has_form = callable(getattr(REGISTRY[name], FORMS[kind], None))
    assert has_form == catalog.serves(name, kind)
    if has_form:
        assert model_form(name, kind) == getattr(REGISTRY[name], FORMS[kind])
    else:
        with pytest.raises(ValueError, match=f"does not serve {kind} scenes"):
            model_form(name, kind)


def test_fidelities_are_the_models_that_build_cars():
    assert set(catalog.FIDELITIES) == {name for name, model in REGISTRY.items() if hasattr(model, "car")}


@pytest.mark.parametrize("name", sorted(REGISTRY))
def test_no_model_serves_a_measured_scene(name):
    """A measured case runs estimators on recorded accelerations; asking a model for it is refused."""
    for kind in catalog.MEASURED_KINDS:
        assert not catalog.serves(name, kind)
        with pytest.raises(ValueError, match=f"does not serve {kind} scenes"):
            model_form(name, kind)
