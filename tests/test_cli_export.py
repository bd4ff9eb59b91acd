"""`follicle export` and `follicle grow -o` in every format: outputs, streaming, errors."""

import numpy as np
import pytest
from click.testing import CliRunner

import follicle
from follicle.cli import main
from follicle.groom import generator
from follicle.io import dispatch
from hairfiles import hair


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    path = tmp_path_factory.mktemp("scene") / "scene.toml"
    path.write_text('[groom]\ncount = 1200\nseed = 3\n[guides]\npath = "builtin:short"\n')
    return path


@pytest.mark.parametrize("ext", [".hair", ".tfx", ".obj", ".txt"])
def test_export_converts_between_formats(tmp_path, ext):
    c = hair()
    source = follicle.save(c, tmp_path / "in.npz")
    result = run("export", source, "-o", tmp_path / f"out{ext}")
    assert result.exit_code == 0, result.output
    assert f"4 hairs, 17 points → {tmp_path / f'out{ext}'}" in result.output
    back = follicle.load_curves(tmp_path / f"out{ext}")
    np.testing.assert_allclose(back.points[back.offsets[:-1]], c.points[c.offsets[:-1]], atol=1e-8)
    assert run("export", tmp_path / f"out{ext}", "-o", tmp_path / "again.npz").exit_code == 0
    assert run("export", source, "-o", tmp_path / "h.pbrt").exit_code == 0


def test_export_refuses_an_unknown_output_extension(tmp_path):
    source = follicle.save(hair(), tmp_path / "in.npz")
    result = run("export", source, "-o", tmp_path / "out.xyz")
    assert result.exit_code == 2
    message = result.output.replace("\n", "")
    assert "out.xyz: output must end in .npz or .abc or .hair or .obj or .pbrt" in message
    assert all(f" {ext}" in message for ext in (".tfx", ".txt"))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.npz"]
    result = run("export", tmp_path / "in.xyz", "-o", tmp_path / "out.hair")
    assert result.exit_code == 2 and "cannot read '.xyz' files" in result.output


@pytest.mark.parametrize("ext", [".hair", ".tfx", ".obj", ".txt"])
def test_export_of_a_corrupted_file_exits_2_and_writes_nothing(tmp_path, ext):
    good = follicle.save(hair(), tmp_path / f"good{ext}").read_bytes()
    bad = tmp_path / f"bad{ext}"
    bad.write_bytes(good[: len(good) // 2] + (b"\nl 99 0\n" if ext == ".obj" else b"x"))
    result = run("export", bad, "-o", tmp_path / "out.npz")
    assert result.exit_code == 2
    assert result.output.startswith("error:") and "bad" in result.output
    assert "Traceback" not in result.output
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([f"good{ext}", f"bad{ext}"])


@pytest.mark.parametrize("ext", [".hair", ".tfx", ".obj", ".pbrt", ".txt"])
@pytest.mark.slow
def test_grow_streams_every_format_chunk_by_chunk(tmp_path, scene, monkeypatch, ext):
    monkeypatch.setattr(generator, "CHUNK", 500)
    chunk_sizes = []
    save = dispatch.save

    def spy(curves, path, **options):
        def chunks():
            for chunk in curves:
                chunk_sizes.append(chunk.curve_count)
                yield chunk

        return save(chunks(), path, **options)

    monkeypatch.setattr(dispatch, "save", spy)
    result = run("grow", scene, "-o", tmp_path / f"g{ext}")
    assert result.exit_code == 0, result.output
    assert "1,200 hairs, 19,200 points" in result.output
    assert chunk_sizes == [500, 500, 200]
    if ext in dispatch.READERS:
        assert run("grow", scene, "-o", tmp_path / "g.npz").exit_code == 0
        whole = follicle.load_curves(tmp_path / "g.npz")
        back = follicle.load_curves(tmp_path / f"g{ext}")
        assert back.curve_count == whole.curve_count
        np.testing.assert_allclose(back.points, whole.points, atol=1e-7)


@pytest.mark.slow
def test_grow_refuses_unknown_extensions_and_writes_an_empty_groom(tmp_path, scene):
    result = run("grow", scene, "-o", tmp_path / "x.xyz")
    assert result.exit_code == 2 and "must end in .npz or .abc or .hair" in result.output
    assert list(tmp_path.iterdir()) == []
    result = run("grow", scene, "--count", 0, "-o", tmp_path / "e.hair")
    assert result.exit_code == 0 and "0 hairs" in result.output
    assert follicle.load_curves(tmp_path / "e.hair").curve_count == 0
