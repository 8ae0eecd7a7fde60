"""dronewind.core.yamltext: libyaml's safe loader gives what PyYAML's safe_load gives."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from dronewind.core.yamltext import SAFE_LOADER, load_yaml

REPO = Path(__file__).resolve().parents[2]
#: Every YAML file of the repository that dronewind reads: manifests, configs, published
#: results, the schemas.
FILES = sorted([*REPO.glob("config/**/*.yaml"), *REPO.glob("workflow/schemas/*.yaml"),
                *REPO.glob("src/dronewind/schemas/*.yaml")])


def test_libyaml_is_used_where_pyyaml_has_it():
    assert SAFE_LOADER is (yaml.CSafeLoader if yaml.__with_libyaml__ else yaml.SafeLoader)


@pytest.mark.parametrize("path", FILES, ids=[str(p.relative_to(REPO)) for p in FILES])
def test_same_content_as_pure_python_safe_load(path):
    text = path.read_text(encoding="utf-8")
    assert load_yaml(text) == yaml.safe_load(text)


def test_implicit_types_and_unsafe_tags():
    text = "a: 2023-08-22T14:05:00Z\nb: 1e3\nc: 1.0e3\nd: yes\ne: ~\nf: 0x10\n"
    assert load_yaml(text) == yaml.safe_load(text)
    with pytest.raises(yaml.YAMLError):
        load_yaml("x: !!python/object/apply:os.system ['true']")


def test_invalid_yaml_names_the_line():
    with pytest.raises(yaml.YAMLError) as err:
        load_yaml("a: 1\nb: [1, 2\nc: 3\n")
    assert err.value.problem_mark.line in (2, 3)  # 0-based: the line where the parser gives up
