"""The text-to-motion pipeline: training data, training, the train-once cache, generate() and its checks."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from motionlab.data import MotionDataset
from motionlab.data.embedded import write_embedded_dataset
from motionlab.diffusion import (
    TextToMotion,
    TextToMotionNetworks,
    TokenBatches,
    TokenRecorder,
    diffusion_training_config,
    evaluate_ground_truth,
    evaluate_text_to_motion,
    make_transitions,
    sample,
    text_to_motion_for_dataset,
    tokenize_clips,
)
from motionlab.diffusion.pipeline import MODEL_NAME, cache_extra
from motionlab.representation import Normalizer
from motionlab.text import Vocabulary, WordTextEncoder
from motionlab.tokenizers import VQVAE, vq_config
from motionlab.train import artefact_dir, is_trained
from motionlab.train.checkpoint import load_weights, save_weights

CAPTIONS = ["a person walks forward", "someone jumps up high", "a man waves his right hand"]


def tiny_pipeline(eta: float = 0.5, T: int = 10) -> TextToMotion:
    """An untrained but complete pipeline (smoke-sized VQ, K = 32) for the API tests."""
    tokenizer = VQVAE(vq_config("smoke")).eval()
    config = diffusion_training_config("smoke", num_codes=tokenizer.codebook_size, eta=eta, timesteps=T)
    nets = TextToMotionNetworks(config, Vocabulary.build(CAPTIONS)).eval()
    transitions = make_transitions(config.transformer, tokenizer.codebook())
    normalizer = Normalizer(np.zeros(263, np.float32), np.ones(263, np.float32))
    return TextToMotion(tokenizer, nets.text_encoder, nets.denoiser, transitions, normalizer, config.transformer)


@pytest.fixture(scope="module")
def pipe() -> TextToMotion:
    return tiny_pipeline()


# ------------------------------------------------------------------------------------------- generate()


def test_generate_returns_the_requested_lengths(pipe):
    motions = pipe.generate(CAPTIONS, [8, 20, 4], seed=0, num_steps=3)
    assert [m.shape for m in motions] == [(8, 263), (20, 263), (4, 263)]
    assert all(np.isfinite(m).all() for m in motions)
    ids = pipe.sample_tokens(CAPTIONS, [8, 20, 4], generator=torch.Generator().manual_seed(0), num_steps=3)
    assert ids.shape == (3, 5)
    assert (ids[0, 2:] == -1).all() and (ids[2, 1:] == -1).all()  # padding after each length
    assert ((ids[1] >= 0) & (ids[1] < 32)).all()  # full rows hold codes only, never the mask


def test_generate_is_deterministic_under_a_seed(pipe):
    a = pipe.generate(CAPTIONS[:2], [12, 16], seed=3, num_steps=4)
    b = pipe.generate(CAPTIONS[:2], [12, 16], seed=3, num_steps=4)
    c = pipe.generate(CAPTIONS[:2], [12, 16], seed=4, num_steps=4)
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    assert not all(np.array_equal(x, y) for x, y in zip(a, c, strict=True))


def test_batching_does_not_change_the_shapes_or_the_codes_range(pipe):
    ids = pipe.sample_tokens(
        CAPTIONS * 2, [8] * 6, generator=torch.Generator().manual_seed(1), num_steps=2, batch_size=4, guidance_scale=0.0
    )
    assert ids.shape == (6, 2) and ids.min() >= 0 and ids.max() < 32


@pytest.mark.parametrize(
    ("texts", "lengths", "match"),
    [
        (["a person walks"], [10], "multiples of 4"),
        (["a person walks"], [0], "multiples of 4"),
        (["a person walks"], [8.0], "multiples of 4"),
        ([], [], "non-empty"),
        ("a person walks", [8], "single str"),
        (["a person walks", "someone jumps"], [8], "2 texts"),
        (["a person walks"], [8, 12], "1 texts"),
    ],
)
def test_bad_inputs_raise_value_errors(pipe, texts, lengths, match):
    with pytest.raises(ValueError, match=match):
        pipe.generate(texts, lengths, seed=0, num_steps=2)


@pytest.fixture(scope="module")
def loud_pipe() -> TextToMotion:
    """The tiny pipeline with large random weights, so that guided and unguided branches differ visibly."""
    pipe = tiny_pipeline()
    g = torch.Generator().manual_seed(5)
    with torch.no_grad():
        for p in [*pipe.model.parameters(), *pipe.text_encoder.parameters()]:
            if p.ndim >= 2:
                p.normal_(0.0, 0.3, generator=g)
    return pipe


def test_sample_tokens_passes_guidance_on_to_the_sampler(loud_pipe):
    lengths = [16, 20, 24]  # in length order: the pipeline samples them in this order too
    kw = dict(num_steps=4, guidance_scale=4.0)
    feats = loud_pipe.encode_texts(CAPTIONS)
    ids = {}
    for space in ("x0", "posterior"):
        ids[space] = loud_pipe.sample_tokens(
            CAPTIONS, lengths, generator=torch.Generator().manual_seed(0), guidance_on=space, **kw
        )
        direct = sample(
            loud_pipe.model,
            loud_pipe.transitions,
            feats.tokens,
            feats.padding_mask,
            lengths=[n // 4 for n in lengths],
            generator=torch.Generator().manual_seed(0),
            guidance_on=space,
            **kw,
        )
        assert torch.equal(ids[space], direct)
    default = loud_pipe.sample_tokens(CAPTIONS, lengths, generator=torch.Generator().manual_seed(0), **kw)
    assert torch.equal(default, ids["x0"])  # VQ-Diffusion's placement is the default
    assert not torch.equal(ids["x0"], ids["posterior"])
    motions = loud_pipe.generate(CAPTIONS, lengths, seed=0, guidance_on="posterior", **kw)
    assert [m.shape for m in motions] == [(n, 263) for n in lengths]
    with pytest.raises(ValueError, match="guidance_on"):
        loud_pipe.generate(CAPTIONS, lengths, seed=0, guidance_on="logits", **kw)


def test_sample_tokens_batches_texts_by_length_and_answers_in_request_order(loud_pipe):
    lengths, order = [24, 8, 16], [1, 2, 0]  # shortest first
    kw = dict(num_steps=4, guidance_scale=2.0)
    ids = loud_pipe.sample_tokens(CAPTIONS, lengths, generator=torch.Generator().manual_seed(0), batch_size=2, **kw)
    assert [int((row >= 0).sum()) for row in ids] == [n // 4 for n in lengths]
    generator, rows = torch.Generator().manual_seed(0), []
    for batch in ([1, 2], [0]):  # what the pipeline does: lengths 8 and 16 together, then 24 alone
        feats = loud_pipe.encode_texts([CAPTIONS[i] for i in batch])
        rows += list(
            sample(
                loud_pipe.model,
                loud_pipe.transitions,
                feats.tokens,
                feats.padding_mask,
                lengths=[lengths[i] // 4 for i in batch],
                generator=generator,
                **kw,
            )
        )
    for i, row in zip(order, rows):
        n = lengths[i] // 4
        assert torch.equal(ids[i, :n], row[:n])


def test_generate_with_tokens_returns_the_decoded_tokens_and_the_recorder_keeps_them(loud_pipe):
    lengths = [16, 8, 12]
    motions, ids = loud_pipe.generate_with_tokens(CAPTIONS, lengths, seed=2, num_steps=3)
    again = loud_pipe.generate(CAPTIONS, lengths, seed=2, num_steps=3)
    assert all(np.array_equal(a, b) for a, b in zip(motions, again, strict=True))
    assert all(np.array_equal(m, d) for m, d in zip(motions, loud_pipe.decode(ids), strict=True))
    assert ids.shape == (3, 4) and (ids[1, 2:] == -1).all()

    recorder = TokenRecorder(loud_pipe)
    runs = evaluate_text_to_motion(
        recorder,
        RecordingEvaluator(),
        [Clip(16, [Caption("a")]), Clip(9, [Caption("b")])],
        repeats=2,
        seed=0,
        num_steps=3,
    )
    assert len(runs) == 2 and len(recorder.tokens) == 2
    assert [len(s) for s in recorder.all_tokens()] == [4, 2, 4, 2]
    with pytest.raises(ValueError, match="TextToMotion"):
        TokenRecorder(object())


def test_decode_rejects_ids_that_are_not_codes_then_padding(pipe):
    with pytest.raises(ValueError, match="followed only by -1"):
        pipe.decode(torch.tensor([[1, -1, 2]]))
    with pytest.raises(ValueError, match="followed only by -1"):
        pipe.decode(torch.tensor([[1, 32]]))  # 32 is the mask id, not a code
    with pytest.raises(ValueError, match="seed"):
        pipe.generate(CAPTIONS[:1], [8], seed=-1)


# ---------------------------------------------------------------------------------------- training data


def test_token_batches_crop_pad_and_index_captions():
    g = torch.Generator().manual_seed(0)
    seqs = [torch.arange(3), torch.arange(10, 30), torch.arange(40, 47)]
    caps = [["a"], ["b", "c"], ["d", "e", "f"]]
    batches = TokenBatches(seqs, caps, batch_size=64, max_tokens=8)
    batch = batches(0, g)
    ids, pad, cap = batch["ids"], batch["padding_mask"], batch["caption"]
    assert ids.shape[0] == 64 and ids.shape[1] <= 8 and pad.shape == ids.shape
    owner = {"a": 0, "b": 1, "c": 1, "d": 2, "e": 2, "f": 2}
    for b in range(64):
        clip = owner[batches.texts[int(cap[b])]]
        n = int((~pad[b]).sum())
        assert n == min(len(seqs[clip]), 8) and pad[b, n:].all()
        crop = ids[b, :n]
        start = int(crop[0]) - int(seqs[clip][0])
        assert torch.equal(crop, seqs[clip][start : start + n])  # a contiguous window of the clip's tokens
    assert {batches.texts[int(i)] for i in cap} == set("abcdef")  # every caption gets drawn
    again = batches(0, torch.Generator().manual_seed(0))
    assert all(torch.equal(batch[k], again[k]) for k in batch)


def test_fixed_shape_batches_pad_the_same_draws_and_leave_the_networks_outputs_alone():
    """What CUDA graphs need (one shape for every batch): the same rows padded further, and the padding masked so
    well that the text encoder's and the denoiser's outputs at the real positions do not change."""
    config = diffusion_training_config("smoke", num_codes=32)
    rng = np.random.default_rng(1)
    seqs = [torch.from_numpy(rng.integers(0, 32, size=n)) for n in (3, 20, 7, 49, 60, 1, 12)]
    caps = [[f"clip {i} caption {k} " + "word " * int(rng.integers(0, 9)) for k in range(i % 3 + 1)] for i in range(7)]
    nets = TextToMotionNetworks(config, Vocabulary.build([t for c in caps for t in c])).eval()
    tokenize = nets.text_encoder.tokenize
    varying = TokenBatches(seqs, caps, batch_size=4, max_tokens=64, tokenize=tokenize)
    fixed = TokenBatches(seqs, caps, batch_size=4, max_tokens=64, tokenize=tokenize, fixed_shapes=True)
    widest_caption = tokenize(varying.texts)[0].shape[1]
    widths = set()
    for seed in range(6):
        a, b = varying(seed, torch.Generator().manual_seed(seed)), fixed(seed, torch.Generator().manual_seed(seed))
        L, S = a["ids"].shape[1], a["text_ids"].shape[1]
        widths.add((L, S))
        assert b["ids"].shape == (4, 60) and b["text_ids"].shape == (4, widest_caption)  # the longest clip: 60
        assert torch.equal(a["caption"], b["caption"])
        for key, width in (("ids", L), ("padding_mask", L), ("text_ids", S), ("text_padding_mask", S)):
            assert torch.equal(b[key][:, :width], a[key])
        assert b["padding_mask"][:, L:].all() and b["text_padding_mask"][:, S:].all()
        with torch.no_grad():
            outputs = []
            for batch in (a, b):
                text = nets.text_encoder.encode_tokens(batch["text_ids"], batch["text_padding_mask"])
                x_t = batch["ids"].masked_fill(batch["padding_mask"], 32)
                t = torch.full((4,), 5)
                log_p = nets.denoiser(x_t, t, text.tokens, text.padding_mask, padding_mask=batch["padding_mask"])
                outputs.append((text, log_p))
        (text_a, log_p_a), (text_b, log_p_b) = outputs
        words, real = ~a["text_padding_mask"], ~a["padding_mask"]
        torch.testing.assert_close(text_b.tokens[:, :S][words], text_a.tokens[words])
        torch.testing.assert_close(text_b.sentence, text_a.sentence)
        torch.testing.assert_close(log_p_b[:, :L][real], log_p_a[real])  # (B, L, K) at the real tokens
    # padding was added along both axes
    assert any(L < 60 for L, _ in widths) and any(S < widest_caption for _, S in widths)


def test_a_graphed_denoiser_trains_on_fixed_shapes_and_marks_every_step(monkeypatch):
    """Where the denoiser trains as CUDA graphs (forced here: this machine may have no GPU), its trainer pads every
    batch to one shape and tells the graphs at each step that a new iteration began."""
    import motionlab.diffusion.training as training

    config = diffusion_training_config("smoke", num_codes=32)
    rng = np.random.default_rng(2)
    seqs = [torch.from_numpy(rng.integers(0, 32, size=n)) for n in (5, 9, 14, 3)]
    caps = [[f"clip {i} " + "word " * i] for i in range(4)]
    nets = TextToMotionNetworks(config, Vocabulary.build([c[0] for c in caps]))
    transitions = make_transitions(config.transformer, torch.randn(32, config.transformer.d_model))
    marks = []
    monkeypatch.setattr(training, "compile_for_training", lambda *args: True)
    monkeypatch.setattr(torch.compiler, "cudagraph_mark_step_begin", lambda: marks.append(1))
    plain = training.text_to_motion_trainer(nets, seqs, caps, transitions, config, device="cpu", progress=False)
    assert not plain.marks_graph_steps and not plain.batch_fn.fixed_shapes  # on a CPU: never graphed
    monkeypatch.setattr(training, "uses_cuda_graphs", lambda part, device: part == "denoiser")
    trainer = training.text_to_motion_trainer(nets, seqs, caps, transitions, config, device="cpu", progress=False)
    assert trainer.marks_graph_steps and trainer.batch_fn.fixed_shapes
    shapes = {tuple(trainer.batch_fn(step, torch.Generator().manual_seed(step))["ids"].shape) for step in range(4)}
    assert shapes == {(config.transformer.batch_size, min(config.max_tokens, 14))}
    for _ in range(3):
        trainer.train_step()
    assert len(marks) == 3


def test_token_batches_validate_their_inputs():
    with pytest.raises(ValueError, match="as many caption lists"):
        TokenBatches([torch.arange(3)], [["a"], ["b"]], 4, 8)
    with pytest.raises(ValueError, match="at least one caption"):
        TokenBatches([torch.arange(3)], [[]], 4, 8)


def test_tokenize_clips_equals_encoding_each_clip_alone():
    tokenizer = VQVAE(vq_config("smoke")).eval()
    rng = np.random.default_rng(0)
    clips = [rng.normal(size=(n, 263)).astype(np.float32) for n in (18, 16, 18, 9)]
    out = tokenize_clips(tokenizer, clips, batch_size=2)
    assert [len(s) for s in out] == [4, 4, 4, 2]
    for clip, seq in zip(clips, out, strict=True):
        n = len(clip) // 4 * 4
        assert torch.equal(seq, tokenizer.encode(torch.from_numpy(clip[None, :n]))[0])


def test_networks_round_trip_through_safetensors(tmp_path):
    config = diffusion_training_config("smoke", num_codes=16)
    vocab = Vocabulary.build(CAPTIONS)
    nets = TextToMotionNetworks(config, vocab)
    with torch.no_grad():
        nets.denoiser.head.bias.add_(1.0)
    save_weights(nets.state_dict(), tmp_path / "m.safetensors")
    fresh = TextToMotionNetworks(config, vocab)
    load_weights(fresh, tmp_path / "m.safetensors")
    assert torch.equal(fresh.denoiser.head.bias, nets.denoiser.head.bias)
    assert fresh.text_encoder.vocab.tokens == vocab.tokens


def test_config_validation_and_eta_zero_is_uniform():
    with pytest.raises(ValueError, match="distance"):
        diffusion_training_config("smoke", num_codes=16, distance="manhattan")
    with pytest.raises(ValueError, match="schedule"):
        diffusion_training_config("smoke", num_codes=16, schedule="cosine")
    with pytest.raises(ValueError, match="eta"):
        diffusion_training_config("smoke", num_codes=16, eta=float("nan"))
    uniform = make_transitions(diffusion_training_config("smoke", num_codes=16, eta=0.0).transformer)
    assert uniform.distance_kind is None
    codebook = torch.randn(16, 4, generator=torch.Generator().manual_seed(0))
    dynamic = make_transitions(diffusion_training_config("smoke", num_codes=16).transformer, codebook)
    assert dynamic.eta == 0.5 and dynamic.distance_kind == "l2_rank"
    with pytest.raises(ValueError, match="codebook"):
        make_transitions(diffusion_training_config("smoke", num_codes=16).transformer)


def test_eta_and_distance_enter_the_cache_key(isolated_cache):
    extra = {"data": "x"}

    def key(**kw):
        return artefact_dir(MODEL_NAME, diffusion_training_config("smoke", num_codes=32, **kw), "smoke", extra)

    assert key(eta=0.0) != key(eta=0.5)
    assert key(eta=0.5, distance="l2_rank") != key(eta=0.5, distance="cosine")
    assert key(eta=0.5) != key(eta=0.5, schedule="vqdiffusion_code")
    assert key(eta=0.0, distance="l2_rank") == key(eta=0.0, distance="cosine")  # uniform: no distance
    assert key() == key(eta=0.5)  # the paper's η is the default


def test_training_seed_enters_the_cache_key_and_seed_0_is_the_shared_model(isolated_cache, monkeypatch):
    import motionlab.diffusion.pipeline as pipeline

    seen = []

    class Stop(Exception):
        pass

    def fake_train_or_load(name, config, *args, **kwargs):
        seen.append(config)
        raise Stop

    monkeypatch.setattr(pipeline, "train_or_load", fake_train_or_load)
    dataset = MotionDataset(write_embedded_dataset(isolated_cache / "data", n_clips=42, progress=False, workers=1))
    for seed in (None, 0, 1):
        with pytest.raises(Stop):
            text_to_motion_for_dataset(dataset, "smoke", seed=seed, progress=False)
    key = lambda c: artefact_dir(MODEL_NAME, c, "smoke", {"data": "x"})  # noqa: E731
    assert [c.seed for c in seen] == [0, 0, 1]
    assert key(seen[0]) == key(seen[1]) != key(seen[2])
    with pytest.raises(ValueError, match="seed"):
        text_to_motion_for_dataset(dataset, "smoke", seed=-1, progress=False)


# ---------------------------------------------------------------------------------------- end to end


def test_training_reduces_the_loss_and_is_cached(isolated_cache, tmp_path):
    dataset = MotionDataset(write_embedded_dataset(tmp_path / "data", n_clips=42, progress=False, workers=1))
    config = diffusion_training_config("smoke", num_codes=vq_config("smoke").codebook_size, train_steps=60)
    pipe = text_to_motion_for_dataset(dataset, "smoke", config=config, progress=False)
    rows = [r for r in pipe.history if "loss" in r]
    assert len(rows) == 6
    first, last = rows[0], rows[-1]
    assert last["aux"] < first["aux"] - 0.2  # -log p(x_0 | x_t) in nats, from about log K = 3.47
    assert np.mean([r["loss"] for r in rows[-2:]]) < np.mean([r["loss"] for r in rows[:2]])

    extra = cache_extra(dataset, pipe.tokenizer, pipe.text_encoder.vocab)
    assert is_trained(MODEL_NAME, config, "smoke", extra)
    again = text_to_motion_for_dataset(dataset, "smoke", config=config, progress=False)  # loaded, not trained
    assert all(
        torch.equal(a, b)
        for a, b in zip(pipe.model.state_dict().values(), again.model.state_dict().values(), strict=True)
    )
    assert again.history == pipe.history

    test = dataset.split("test")[:3]
    lengths = [len(c.features) // 4 * 4 for c in test]
    motions = again.generate([c.captions[0].text for c in test], lengths, seed=0, num_steps=5)
    assert [m.shape for m in motions] == [(n, 263) for n in lengths]
    with pytest.raises(ValueError, match="either config"):
        text_to_motion_for_dataset(dataset, "smoke", config=config, eta=0.0, progress=False)


def test_a_model_trained_as_cuda_graphs_has_its_own_cache_key(isolated_cache, tmp_path, monkeypatch):
    """``--compile graphs`` pads every batch to one shape, so the model trains on other data: it must not be served
    as (or resume from) the default model, and the default model's key must stay what it was."""
    from motionlab.diffusion import pipeline

    dataset = MotionDataset(write_embedded_dataset(tmp_path / "data", n_clips=42, progress=False, workers=1))
    keys = []

    def spy(name, config, build, train_fn, profile, *, extra, **kwargs):
        keys.append(dict(extra))
        raise RuntimeError("stop before training")

    monkeypatch.setattr(pipeline, "train_or_load", spy)
    for graphs in (False, True):
        monkeypatch.setattr(pipeline, "uses_cuda_graphs", lambda part, device, graphs=graphs: graphs)
        with pytest.raises(RuntimeError, match="stop before training"):
            text_to_motion_for_dataset(dataset, "smoke", progress=False)
    default, graphed = keys
    assert "compile" not in default  # the key every cached default model was trained under
    assert graphed == {**default, "compile": "graphs"}


# ------------------------------------------------------------------------------------------ evaluation


class RecordingEvaluator:
    """Records what the protocol hands it; scores a run by the mean absolute feature of the motions."""

    def __init__(self):
        self.calls = []

    def evaluate_generation(self, gt_clips, generated, captions, rng):
        self.calls.append(([len(m) for m in generated], [c.text for c in captions]))
        return {"fid": float(np.mean([np.abs(m).mean() for m in generated])), "top1": float(rng.random())}


class Clip:
    def __init__(self, n, captions):
        self.features = np.zeros((n, 263), np.float32)
        self.captions = captions


class Caption:
    def __init__(self, text):
        self.text = text


def test_evaluation_protocol_generates_at_clip_lengths_and_varies_seeds():
    clips = [Clip(13, [Caption("a"), Caption("b")]), Clip(20, [Caption("c")]), Clip(7, [Caption("d")])]
    seeds = []

    def generate(texts, lengths, seed, **sampling):
        seeds.append(seed)
        assert sampling == {"num_steps": 3}
        return [np.full((n, 263), seed + 1.0) for n in lengths]

    evaluator = RecordingEvaluator()
    runs = evaluate_text_to_motion(generate, evaluator, clips, repeats=3, seed=2, num_steps=3)
    assert len(runs) == 3 and seeds == [2000, 2001, 2002]
    assert all(lengths == [12, 20, 4] for lengths, _ in evaluator.calls)
    assert [r["fid"] for r in runs] == [2001.0, 2002.0, 2003.0]
    gt = evaluate_ground_truth(RecordingEvaluator(), clips, repeats=2, seed=2)
    assert len(gt) == 2 and all(r["fid"] == 0.0 for r in gt)
    with pytest.raises(ValueError, match="repeats"):
        evaluate_text_to_motion(generate, evaluator, clips, repeats=0)


class OnesDecoder:
    """A stand-in for the DisCoRD flow decoder: records its arguments and returns ones (normalised)."""

    def __init__(self):
        self.seen = []

    def decode(self, ids, tokenizer=None, steps=None, generator=None):
        self.seen.append((tuple(ids.shape), steps, generator is not None))
        return torch.ones(ids.shape[0], 4 * ids.shape[1], 263)


def test_decode_with_another_decoder_and_reconstruct(pipe):
    decoder = OnesDecoder()
    motions = pipe.generate(CAPTIONS[:2], [8, 12], seed=0, num_steps=2, decoder=decoder, steps=3)
    assert decoder.seen == [((1, 2), 3, True), ((1, 3), 3, True)]  # one clip at a time, no padding
    assert all(np.array_equal(m, np.ones_like(m)) for m in motions)  # denormalised with mean 0, std 1
    recon = pipe.reconstruct([np.zeros((13, 263), np.float32), np.zeros((8, 263), np.float32)])
    assert [r.shape for r in recon] == [(12, 263), (8, 263)]


def token_batch_item_by_item(batches, generator):
    """The per-row path the gather replaced: crop and pad each drawn clip in a Python loop."""
    B = batches.batch_size
    clips = torch.randint(len(batches.sequences), (B,), generator=generator)
    u = torch.rand(B, 2, generator=generator)
    crops = []
    for b, c in enumerate(clips.tolist()):
        seq = batches.sequences[c]
        keep = min(seq.numel(), batches.max_tokens)
        start = int(u[b, 0] * (seq.numel() - keep + 1))
        crops.append(seq[start : start + keep])
    L = max(c.numel() for c in crops)
    ids, padding = torch.zeros(B, L, dtype=torch.long), torch.ones(B, L, dtype=torch.bool)
    for b, crop in enumerate(crops):
        ids[b, : crop.numel()], padding[b, : crop.numel()] = crop, False
    caption = batches.first_caption[clips] + (u[:, 1] * batches.n_captions[clips]).long()
    return {"ids": ids, "padding_mask": padding, "caption": caption}


def test_token_batches_gather_what_the_per_row_path_built_and_tokenize_captions_once():
    rng = np.random.default_rng(0)
    seqs = [torch.from_numpy(rng.integers(0, 50, size=n)) for n in (3, 20, 7, 49, 60, 1, 12)]
    caps = [[f"clip {i} caption {k} " + "word " * int(rng.integers(0, 9)) for k in range(i % 3 + 1)] for i in range(7)]
    encoder = WordTextEncoder.from_captions([t for c in caps for t in c], dim=8, n_layers=1, n_heads=2)
    batches = TokenBatches(seqs, caps, batch_size=96, max_tokens=16, tokenize=encoder.tokenize)
    for seed in range(6):
        batch = batches(seed, torch.Generator().manual_seed(seed))
        expected = token_batch_item_by_item(batches, torch.Generator().manual_seed(seed))
        assert all(torch.equal(batch[k], expected[k]) for k in expected)
        ids, pad = encoder.tokenize([batches.texts[int(i)] for i in batch["caption"]])
        assert torch.equal(batch["text_ids"], ids) and torch.equal(batch["text_padding_mask"], pad)
