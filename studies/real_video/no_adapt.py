"""The temporal model without per-clip adaptation, as a gap filler for
``benchmarks/video_protocols.py --method`` (what adaptation buys on mocap)::

    PYTHONPATH=studies/real_video python benchmarks/video_protocols.py --methods akima \\
        --method temporal_no_adapt=no_adapt:recover_track_no_adapt --splits validation
"""

from sparseedm.temporal.recover import recover_track


def recover_track_no_adapt(poses, missing, frames, dictionary=None):
    """:func:`sparseedm.temporal.recover.recover_track` with ``adapt=False``."""
    return recover_track(poses, missing, frames, dictionary=dictionary, adapt=False)


if __name__ == "__main__":
    import argparse

    argparse.ArgumentParser(description=__doc__.splitlines()[0] + " (a module of gap "
                            "fillers: nothing to run by itself)").parse_args()
