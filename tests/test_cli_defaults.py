"""The CLI states its defaults without importing the API (a fast ``--help``);
these tests keep each stated default equal to the API's, so they cannot drift."""

import inspect

import pytest

from sparseedm.batch import recover_file
from sparseedm.cli import build_parser, main
from sparseedm.dataset import build_dataset
from sparseedm.evaluation import evaluate
from sparseedm.evaluation_real import evaluate_photos, evaluate_tracks
from sparseedm.learning import fit_dictionary_file
from sparseedm.lifting.evaluation import evaluate_lifting
from sparseedm.lifting.io import lift_file
from sparseedm.plotting import plot_recovery
from sparseedm.temporal.evaluation import evaluate_video


def api(func, name):
    return inspect.signature(func).parameters[name].default


CASES = [  # (command line, option dest, API function, its parameter)
    (["recover", "in.csv", "-o", "out.csv"], [
        ("chunk_size", recover_file, "chunk_size"),
        ("confidence_threshold", recover_file, "confidence_threshold"),
        ("jobs", recover_file, "n_jobs"),
        ("self_training", recover_file, "self_training"),
        ("ensemble", recover_file, "ensemble"),
        ("joint_map", recover_file, "joint_map"),
        ("input_format", recover_file, "input_format"),
        ("filled_score", recover_file, "filled_score"),
        ("representation", recover_file, "representation"),
        ("preset", recover_file, "preset")]),
    (["evaluate", "--data", "t.npz", "-o", "rep"], [
        ("max_train", evaluate, "max_train"),
        ("seed", evaluate, "random_state"),
        ("jobs", evaluate, "n_jobs"),
        ("self_training", evaluate, "self_training"),
        ("ensemble", evaluate, "ensemble")]),
    (["evaluate", "--protocol", "gaps", "--data", "s.npz", "-o", "rep"], [
        ("seed", evaluate_video, "random_state"),
        ("gap_lengths", evaluate_video, "gap_lengths"),
        ("noise", evaluate_video, "noise")]),
    (["evaluate", "--protocol", "photos", "--data", "k.csv", "-o", "rep"], [
        ("seed", evaluate_photos, "random_state"),
        ("conditions", evaluate_photos, "conditions")]),
    (["evaluate", "--protocol", "video-real", "--data", "k.csv", "-o", "rep"], [
        ("seed", evaluate_tracks, "random_state"),
        ("gap_lengths", evaluate_tracks, "gap_lengths"),
        ("min_frames", evaluate_tracks, "min_frames"),
        ("max_clips", evaluate_tracks, "max_clips")]),
    (["evaluate-lift", "--data", "t.npz", "-o", "rep"], [
        ("max_train", evaluate_lifting, "max_train"),
        ("seed", evaluate_lifting, "seed"),
        ("jobs", evaluate_lifting, "n_jobs")]),
    (["lift", "in.csv", "-o", "out.csv"], [
        ("confidence_threshold", lift_file, "confidence_threshold"),
        ("jobs", lift_file, "n_jobs"),
        ("input_format", lift_file, "input_format"),
        ("representation", lift_file, "representation"),
        ("frames", lift_file, "plot_frames"),
        ("track", lift_file, "track")]),
    (["plot", "in.csv", "out.csv", "-o", "f.png"], [
        ("poses", plot_recovery, "n_poses"),
        ("tracks", plot_recovery, "show_tracks"),
        ("frames", plot_recovery, "show_frames"),
        ("rows", plot_recovery, "show_rows"),
        ("joints", plot_recovery, "show_joints")]),
    (["dataset", "build", "mocap", "-o", "d.npz"], [
        ("cameras_per_pose", build_dataset, "cameras_per_pose"),
        ("seed", build_dataset, "random_state"),
        ("camera_per", build_dataset, "camera")]),
    (["fit", "t.npz", "-o", "d.npz"], [
        ("seed", fit_dictionary_file, "random_state"),
        ("passes", fit_dictionary_file, "n_passes"),
        ("errors", fit_dictionary_file, "errors_path")]),
]


@pytest.mark.parametrize("argv,pairs", CASES, ids=[" ".join(c[0][:3]) for c in CASES])
def test_cli_defaults_are_the_apis(argv, pairs):
    args = build_parser().parse_args(argv)
    for dest, func, name in pairs:
        assert getattr(args, dest) == api(func, name), (argv[0], dest)


def test_outlier_check_is_on_by_default_in_both():
    args = build_parser().parse_args(["recover", "in.csv", "-o", "out.csv"])
    assert (not args.no_outliers) is api(recover_file, "outliers") is True
    args = build_parser().parse_args(["recover", "in.csv", "-o", "out.csv", "--no-outliers"])
    assert args.no_outliers


def test_input_formats_are_the_ones_read_keypoints_reads():
    """--input-format names every format read_keypoints reads (and its aliases), no other."""
    from pathlib import Path

    from sparseedm.cli._common import INPUT_FORMATS
    from sparseedm.keypoints import FORMATS, format_of

    assert set(FORMATS) <= set(INPUT_FORMATS)
    assert {format_of(Path("in"), f) for f in INPUT_FORMATS} == set(FORMATS)
    for argv in (["recover", "in"], ["lift", "in"], ["plot", "in", "out"], ["fit", "in"]):
        args = build_parser().parse_args(argv + ["-o", "o.csv", "--input-format", "csv"])
        assert args.input_format == "csv"


def test_video_evaluation_methods_are_the_apis():
    from sparseedm.cli._evaluate_video import VIDEO_METHODS

    assert tuple(VIDEO_METHODS.split(",")) == api(evaluate_video, "methods")


@pytest.mark.parametrize("init", [None, "default"])
def test_fit_leaves_unset_options_to_the_api(tmp_path, monkeypatch, init):
    """`fit` passes no batch size, alpha or recovery alpha it was not given: learning
    from scratch (512) and fine-tuning (the adaptation's 256) keep their own defaults."""
    import sparseedm.adaptation
    import sparseedm.learning

    seen = {}

    class Stop(BaseException):  # not an Exception: main() turns those into exit 3
        pass

    def spy(*args, **kwargs):
        seen.update(kwargs)
        raise Stop

    target = (sparseedm.adaptation, "fine_tune_file") if init else \
        (sparseedm.learning, "fit_dictionary_file")
    monkeypatch.setattr(*target, spy)
    argv = ["fit", str(tmp_path / "t.npz"), "-o", str(tmp_path / "d.npz")]
    with pytest.raises(Stop):
        main(argv + (["--init", init] if init else []))
    assert "batch_size" not in seen
    if not init:
        assert "alpha" not in seen and "alpha_recover" not in seen
        assert "n_components" not in seen  # --atoms unset: the API's 2000
    seen.clear()
    with pytest.raises(Stop):
        main(argv + (["--init", init] if init else []) + ["--batch-size", "64"])
    assert seen["batch_size"] == 64
    if not init:
        seen.clear()
        with pytest.raises(Stop):
            main(argv + ["--atoms", "50"])
        assert seen["n_components"] == 50


def test_fit_atoms_help_states_the_apis_default():
    """--atoms is None unless given (so --init can refuse it); its help states the
    API's default, which applies when it is left out."""
    sub = next(a for a in build_parser()._actions if a.dest == "command").choices["fit"]
    atoms = next(a for a in sub._actions if a.dest == "atoms")
    assert atoms.default is None
    assert f"(default {api(fit_dictionary_file, 'n_components')};" in atoms.help


@pytest.mark.parametrize("extra,named", [
    (["--atoms", "2000"], "--atoms does not"),      # the default's value, given: refused
    (["--checkpoint", "c.npz"], "--checkpoint does not"),
    (["--resume"], "--resume does not"),
    (["--positive-code"], "--positive-code does not"),
    (["--atoms", "0", "--checkpoint", "c.npz", "--resume"],
     "--atoms, --checkpoint and --resume do not")])
def test_fit_init_refuses_the_options_of_learning_from_scratch(tmp_path, monkeypatch, capsys,
                                                                extra, named):
    """`fit --init` used to ignore --atoms, --checkpoint, --resume (and --positive-code)
    without a word: refused before any work (exit 2), naming them."""
    import sparseedm.adaptation

    def no_work(*args, **kwargs):
        raise AssertionError("fine-tuned with an option it ignores")

    monkeypatch.setattr(sparseedm.adaptation, "fine_tune_file", no_work)
    out = tmp_path / "d.npz"
    assert main(["fit", str(tmp_path / "t.npz"), "-o", str(out), "--init", "default",
                 *extra]) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert f"{named} apply to fine-tuning (--init default)" in err
    assert "drop --init to learn a dictionary from scratch" in err and not out.exists()


def test_recover_presets_are_the_apis(capsys):
    """--preset takes every preset recover() validates, and no other."""
    from sparseedm._recovery_kernel import PRESETS

    for preset in PRESETS:
        args = build_parser().parse_args(["recover", "in", "-o", "o.csv", "--preset", preset])
        assert args.preset == preset
    with pytest.raises(SystemExit):
        build_parser().parse_args(["recover", "in", "-o", "o.csv", "--preset", "fastest"])


def test_fit_lifter_states_the_defaults_it_uses():
    """fit-lifter leaves unset options to lifting.defaults.DEFAULTS: its help states them."""
    from sparseedm.cli import build_parser
    from sparseedm.lifting.defaults import DEFAULTS

    sub = next(a for a in build_parser()._actions if a.dest == "command").choices["fit-lifter"]
    said = {a.dest: " ".join(a.help.split()) for a in sub._actions if a.help}
    d, mlp, fconv = DEFAULTS["dictionary"], DEFAULTS["mlp"], DEFAULTS["fconv"]
    stated = {"atoms": f"(default {d['n_components']})", "alpha_lift": f"(default {d['alpha_lift']})",
              "weight": f"(default {d['weight']:g})", "passes": f"(default {d['n_passes']:g})",
              "decoder_ridge": f"(default {d['decoder_ridge']}",
              "hidden": "(default " + ",".join(map(str, mlp["hidden_layer_sizes"])) + ")",
              "max_iter": f"(default {mlp['max_iter']})",
              "channels": "(default " + ",".join(map(str, fconv["channels"])) + ")",
              "epochs": f"(default {fconv['max_epochs']})",
              "representation": f"(default {fconv['representation']})",
              "normalization": f"(default {d['normalization']})"}
    for dest, text in stated.items():
        assert text in said[dest], (dest, said[dest])
    assert f"(default {d['alpha']})" in said["alpha"] and f"(default {mlp['alpha']:g})" in said["alpha"]


def test_info_names_every_shipped_file(capsys):
    """`sparseedm info --help` names every shipped dictionary and lifter."""
    from sparseedm.dictionary import available_dictionaries
    from sparseedm.lifting.base import available_lifters

    with pytest.raises(SystemExit):
        main(["info", "--help"])
    said = " ".join(capsys.readouterr().out.split()).replace("- ", "-")
    for name in [*available_dictionaries(), *available_lifters()]:
        assert name in said, name


def test_self_training_help_states_the_video_rule():
    """--self-training's default with frames: the rounds run from SELF_TRAINING_MIN_FRAMES
    poses on (sparseedm.temporal.recover.adapts), as recover's and lift's help say."""
    from sparseedm.adaptation import SELF_TRAINING_ROUNDS
    from sparseedm.temporal.recover import SELF_TRAINING_MIN_FRAMES

    sub = next(a for a in build_parser()._actions if a.dest == "command")
    for command in ("recover", "lift"):
        text = " ".join(next(a.help for a in sub.choices[command]._actions
                             if a.dest == "self_training").split())
        assert f"default {SELF_TRAINING_ROUNDS}" in text, command
        assert f"from {SELF_TRAINING_MIN_FRAMES} poses on" in text, command


#: options two commands spell alike for different things: (option, why)
DIFFERENT_MEANINGS = {
    "--joint-map": "a mocap rig's joint map (dataset) or DeepLabCut's body parts (the rest)",
    "--poses": "skeleton panels (plot) or complete,occluded counts (evaluate --protocol photos)",
}


def test_an_option_shared_by_commands_takes_one_metavar():
    """--jobs N, --seed N, --dictionary NAME|PATH...: an option several commands take
    reads the same in each one's help (argparse's default, the option's name in
    capitals, had left fit's --jobs JOBS beside recover's --jobs N)."""
    import argparse
    import collections

    seen = collections.defaultdict(dict)

    def walk(parser, name):
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for sub, subparser in action.choices.items():
                    walk(subparser, f"{name} {sub}".strip())
            elif action.option_strings and action.nargs != 0 and action.choices is None:
                for option in action.option_strings:
                    if option.startswith("--"):
                        seen[option][name] = action.metavar or action.dest.upper()

    walk(build_parser(), "")
    assert len(seen) > 40 and len(seen["--jobs"]) >= 5
    spelled = {option: by for option, by in seen.items()
               if len(set(by.values())) > 1 and option not in DIFFERENT_MEANINGS}
    assert not spelled, spelled
