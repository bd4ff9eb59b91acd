"""The docs gallery's reading of the examples (tools/docs_gallery.py): the commands a
scene's comment names are the ones run, as written, with the gallery's own render in
place of the comment's; the prose is the description; and a build that does not run
the examples shows a note where a page shows their pictures, and only there. (Running
them is tests/test_docs_build.py's.)"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))  # the build hook's own imports (tools/ is no package)

import docs_gallery as gallery  # noqa: E402


def test_a_scene_with_scripts_runs_them_as_its_comment_says():
    example = gallery.example(ROOT / "examples" / "hand_groomed.toml")
    assert example.commands == (
        ".venv/bin/python examples/hand_groomed.py",
        "follicle groom examples/hand_groomed.strokes.json -o examples/assets/hand_groomed.npz"
        " --groups examples/assets/hand_groomed_groups.png",
        "follicle render examples/hand_groomed.toml -o hand_groomed.png --size 360 360"
        " --engine cpu",
    )
    assert example.scripts == ("examples/hand_groomed.py",)
    assert example.title == (
        "A short groom made by hand with the brushes: combed back, a side parting, a fringe "
        "cut straight at the brow."
    )
    assert example.description.startswith("The guides are the built-in short ones")
    assert "follicle" not in example.description.split("`follicle view`")[0]


def test_a_scene_is_rendered_small_on_the_cpu_whatever_its_comment_renders(tmp_path: Path):
    scene = tmp_path / "two.toml"
    scene.write_text(
        "# Two lines\n# of title.\n#\n"
        "#   python3 examples/make.py --flag \\\n#       more   # makes the mesh\n"
        "#   follicle render examples/two.toml -o big.png --size 2000 2000\n#\n"
        "# Then prose.\n\n[mesh]\npath = 'builtin:head'\n# not the comment any more\n",
        encoding="utf-8",
    )
    example = gallery.example(scene)
    assert example.name == "two" and example.title == "Two lines of title."
    assert example.commands == (
        "python3 examples/make.py --flag more",
        "follicle render examples/two.toml -o two.png --size 360 360 --engine cpu",
    )
    assert example.scripts == ("examples/make.py",)
    assert example.description == "Then prose."


def test_every_example_of_the_repository_is_found_with_a_description():
    found = gallery.examples(ROOT)
    assert [e.name for e in found] == sorted(p.stem for p in (ROOT / "examples").glob("*.toml"))
    for example in found:
        assert example.title.endswith(".") and len(example.description) > 100, example.name
        assert example.commands[-1] == gallery.render_command(example.name)
        for script in example.scripts:
            assert (ROOT / script).is_file(), script


def test_a_build_without_the_examples_notes_their_pictures_only():
    text = (
        "![wavy](../examples/wavy.png) ![bust](../bust_front.png)"
        " ![tutorial](grooming_by_hand/fringe.png)"
    )
    done = gallery.unrendered(text, "how-to/grooming.md")
    assert "![wavy]" not in done and "`examples/wavy.png`" in done
    assert "![bust](../bust_front.png)" in done
    assert "![tutorial](grooming_by_hand/fringe.png)" in done
    # the same path seen from the site's root is the gallery's too
    assert "![" not in gallery.unrendered("![w](examples/wavy.png)", "gallery.md")
    assert gallery.unrendered(text, "a/b/c.md") == text  # ../examples from a/b is a/examples
