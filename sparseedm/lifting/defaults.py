"""Default lifter settings, chosen on CMU validation clips (studies/lifting/selection.json,
"shipped"; passes and the 3D-half re-fit: studies/lifting/selection_decoder.json, "chosen")."""

#: method -> constructor parameters used by ``sparseedm fit-lifter`` by default
DEFAULTS = {
    "dictionary": {"n_components": 2000, "alpha": 1.6, "alpha_lift": 0.002, "weight": 1.0,
                   "n_passes": 2, "decoder_ridge": 0.01, "normalization": "tied"},
    "mlp": {"hidden_layer_sizes": (400, 400, 400), "alpha": 1e-4, "max_iter": 200,
            "normalization": "tied"},
    # not selected on validation data: the fconv package's defaults (DMR's setting:
    # complete input), tied like the others (sparseedm/lifting/fconv.py says why)
    "fconv": {"representation": "average", "occluded": (0, 0), "channels": (32, 64),
              "kernel": 3, "max_epochs": 30, "normalization": "tied"},
}
