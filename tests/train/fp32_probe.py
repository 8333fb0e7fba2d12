"""Train and sample a small model of each kind in fp32 and print a SHA-256 of every weight and output, as JSON.

Run by ``test_precision.py::test_fp32_is_bit_identical_to_the_code_before_precision`` twice: once with this
checkout's library, once with the library as it was before precision existed (extracted from git), both on the
same dataset folder. It only calls functions that exist in both versions.

    python fp32_probe.py DATASET_FOLDER   (with MOTIONLAB_HOME pointing at an empty cache)
"""

from __future__ import annotations

import hashlib
import json
import sys

import numpy as np
import torch


def digest(*values) -> str:
    h = hashlib.sha256()
    for value in values:
        if isinstance(value, dict):  # a state dict
            for key in sorted(value):
                h.update(key.encode())
                item = value[key]
                h.update(
                    item.detach().cpu().contiguous().numpy().tobytes() if torch.is_tensor(item) else repr(item).encode()
                )
        elif torch.is_tensor(value):
            h.update(value.detach().cpu().contiguous().numpy().tobytes())
        else:
            h.update(np.ascontiguousarray(value).tobytes())
    return h.hexdigest()


def main(folder: str) -> None:
    import motionlab
    from motionlab.data import load_dataset
    from motionlab.diffusion import text_to_motion_for_dataset
    from motionlab.flow import train_or_load_discord
    from motionlab.metrics.evaluator_training import load_or_train_evaluator
    from motionlab.multimotion import MultiMotionGenerator
    from motionlab.tokenizers import tokenizer_for_dataset

    torch.set_num_threads(1)
    out = {"library": str(motionlab.__file__)}
    dataset = load_dataset(folder)
    clips = dataset.normalized("val")[:4]
    window = torch.from_numpy(np.stack([c[:16] for c in clips])).float()  # (4, 16, 263)
    for kind in ("vq", "rvq"):
        tokenizer = tokenizer_for_dataset(kind, dataset, "smoke", progress=False)
        ids = tokenizer.encode(window)
        out[kind] = digest(tokenizer.state_dict(), ids, tokenizer.decode(ids))
    decoder = train_or_load_discord(dataset, tokenizer, "smoke", progress=False)
    out["discord"] = digest(decoder.state_dict(), decoder.decode(ids, seed=1))
    evaluator = load_or_train_evaluator(dataset, "smoke", progress=False)
    val_motions = [clip.features for clip in dataset.split("val")[:4]]
    out["evaluator"] = digest(evaluator.networks.state_dict(), evaluator.embed_motions(val_motions))
    pipe = text_to_motion_for_dataset(dataset, "smoke", progress=False)
    motion = pipe.generate(["a person walks forward"], [48], seed=3)[0]
    out["diffusion"] = digest(pipe.model.state_dict(), pipe.text_encoder.state_dict(), motion)
    multi = MultiMotionGenerator.from_pipeline(pipe).generate(
        ["a person walks", "a person jumps"], [40, 40], method="tps", seed=2
    )[0]
    out["tps"] = digest(multi.features)
    print(json.dumps(out))


if __name__ == "__main__":
    main(sys.argv[1])
