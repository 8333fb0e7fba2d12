"""The text-motion evaluator: checkpoint compatibility, caller order, words, loss and the official loader."""

import numpy as np
import pytest
import torch
import torch.nn.functional as F
from torch.nn.utils.rnn import pack_padded_sequence

from motionlab.metrics import (
    POS_CATEGORIES,
    CaptionVocabulary,
    EvaluatorConfig,
    LearnedWordEmbedding,
    TextMotionEvaluator,
    WordVectorizer,
    contrastive_loss,
    load_official_evaluator,
    pad_caption,
    pos_category,
)
from motionlab.metrics.evaluator import official_motion_batch

# The compatibility contract: parameter names and shapes of the official t2m ``finest.tar``
# (EricGuo5513/text-to-motion, networks/modules.py with the sizes of EvaluatorModelWrapper).
GRU_KEYS = ["weight_ih_l0", "weight_hh_l0", "bias_ih_l0", "bias_hh_l0"]


def _gru(h: int, d: int) -> dict:
    shapes = {"weight_ih_l0": (3 * h, d), "weight_hh_l0": (3 * h, h), "bias_ih_l0": (3 * h,), "bias_hh_l0": (3 * h,)}
    out = {f"gru.{k}": v for k, v in shapes.items()}
    out.update({f"gru.{k}_reverse": v for k, v in shapes.items()})
    return out


def _head(h: int, out: int) -> dict:
    return {
        "output_net.0.weight": (h, 2 * h),
        "output_net.0.bias": (h,),
        "output_net.1.weight": (h,),
        "output_net.1.bias": (h,),
        "output_net.3.weight": (out, h),
        "output_net.3.bias": (out,),
    }


OFFICIAL_T2M = {
    "movement_encoder": {
        "main.0.weight": (512, 259, 4),
        "main.0.bias": (512,),
        "main.3.weight": (512, 512, 4),
        "main.3.bias": (512,),
        "out_net.weight": (512, 512),
        "out_net.bias": (512,),
    },
    "text_encoder": {
        "pos_emb.weight": (300, 15),
        "pos_emb.bias": (300,),
        "input_emb.weight": (512, 300),
        "input_emb.bias": (512,),
        "hidden": (2, 1, 512),
        **_gru(512, 512),
        **_head(512, 512),
    },
    "motion_encoder": {
        "input_emb.weight": (1024, 512),
        "input_emb.bias": (1024,),
        "hidden": (2, 1, 1024),
        **_gru(1024, 1024),
        **_head(1024, 512),
    },
}

TINY = EvaluatorConfig(
    dim_text_hidden=8, dim_motion_hidden=12, dim_coemb=6, dim_movement_hidden=10, dim_movement_latent=10
)


def tiny_model(seed: int = 0) -> TextMotionEvaluator:
    return TextMotionEvaluator(TINY, generator=torch.Generator().manual_seed(seed)).eval()


def test_state_dict_matches_the_official_checkpoint():
    model = TextMotionEvaluator(EvaluatorConfig.official("t2m"))
    state = model.official_state()
    assert set(state) == set(OFFICIAL_T2M)
    for part, expected in OFFICIAL_T2M.items():
        assert {k: tuple(v.shape) for k, v in state[part].items()} == expected, part
    kit = TextMotionEvaluator(EvaluatorConfig.official("kit")).official_state()
    assert tuple(kit["movement_encoder"]["main.0.weight"].shape) == (512, 247, 4)


def test_init_is_seeded():
    a, b = tiny_model(3), tiny_model(3)
    for (k, v), w in zip(a.state_dict().items(), b.state_dict().values()):
        assert torch.equal(v, w), k


def random_batch(seed: int = 0, b: int = 5, t: int = 24, words: int = 9):
    g = torch.Generator().manual_seed(seed)
    w = torch.randn(b, words, 300, generator=g)
    pos = torch.nn.functional.one_hot(torch.randint(0, 15, (b, words), generator=g), 15).float()
    text_len = torch.tensor([9, 3, 5, 9, 4])[:b]
    motions = torch.randn(b, t, 263, generator=g)
    motion_len = torch.tensor([24, 8, 16, 12, 20])[:b]
    return w, pos, text_len, motions, motion_len


def test_embeddings_come_back_in_the_callers_order():
    model = tiny_model()
    w, pos, tl, m, ml = random_batch()
    with torch.no_grad():
        t_emb, m_emb = model(w, pos, tl, m, ml)
        perm = torch.tensor([3, 0, 4, 1, 2])
        t_perm, m_perm = model(w[perm], pos[perm], tl[perm], m[perm], ml[perm])
    assert t_emb.shape == (5, TINY.dim_coemb) and m_emb.shape == (5, TINY.dim_coemb)
    torch.testing.assert_close(t_perm, t_emb[perm])
    torch.testing.assert_close(m_perm, m_emb[perm])


def test_text_padding_does_not_leak():
    model = tiny_model()
    w, pos, tl, _, _ = random_batch()
    with torch.no_grad():
        full = model.encode_text(w, pos, tl)
        w2 = w.clone()
        w2[1, 3:] = 100.0  # caption 1 has 3 tokens
        assert torch.allclose(model.encode_text(w2, pos, tl), full)
        alone = model.encode_text(w[1:2, :3], pos[1:2, :3], tl[1:2])
    torch.testing.assert_close(alone, full[1:2])


def test_motion_encoder_drops_foot_contacts_and_checks_input():
    model = tiny_model()
    _, _, _, m, ml = random_batch()
    with torch.no_grad():
        base = model.encode_motion(m, ml)
        m2 = m.clone()
        m2[..., -4:] = 7.0
        torch.testing.assert_close(model.encode_motion(m2, ml), base)
    with pytest.raises(ValueError, match=r"\(B, T, 263\)"):
        model.encode_motion(m[..., :250], ml)
    with pytest.raises(ValueError, match="lengths"):
        model.encode_motion(m, ml[:3])
    with pytest.raises(ValueError, match="unit_length"):
        model.encode_motion(m, torch.tensor([24, 2, 16, 12, 20]))


def test_contrastive_loss_by_hand():
    t = torch.tensor([[0.0, 0.0], [3.0, 4.0], [0.0, 12.0]])
    m = torch.tensor([[0.0, 1.0], [3.0, 4.0], [0.0, 12.0]])
    out = contrastive_loss(t, m, margin=10.0, shift=1)
    d_pos = torch.tensor([1.0, 0.0, 0.0])
    d_neg = torch.tensor([5.0, 8.544003745317531, 12.0])  # t_i vs m_{i+1}
    torch.testing.assert_close(out.positive, (d_pos**2).mean(), atol=1e-4, rtol=0)
    torch.testing.assert_close(out.negative, ((10 - d_neg).clamp(min=0) ** 2).mean(), atol=1e-4, rtol=0)
    torch.testing.assert_close(out.total, out.positive + out.negative)
    a = contrastive_loss(t, m, generator=torch.Generator().manual_seed(5))
    b = contrastive_loss(t, m, generator=torch.Generator().manual_seed(5))
    assert torch.equal(a.total, b.total)
    with pytest.raises(ValueError, match="shift"):
        contrastive_loss(t, m, shift=0)


# --- words ------------------------------------------------------------------------------------------------


def test_pos_categories_and_vip_override():
    assert len(POS_CATEGORIES) == 15 and POS_CATEGORIES[-1] == "OTHER"
    assert POS_CATEGORIES[pos_category("left", "ADJ")] == "Loc_VIP"
    assert POS_CATEGORIES[pos_category("walk", "VERB")] == "Act_VIP"
    assert POS_CATEGORIES[pos_category("person", "NOUN")] == "NOUN"
    assert POS_CATEGORIES[pos_category("person", "PROPN")] == "OTHER"  # a tag outside the 9
    assert POS_CATEGORIES[pos_category("left", "ADJ", known=False)] == "OTHER"


def test_pad_caption():
    tokens, n = pad_caption(["a/DET", "man/NOUN"])
    assert n == 4 and len(tokens) == 22
    assert tokens[:4] == ["sos/OTHER", "a/DET", "man/NOUN", "eos/OTHER"] and tokens[4] == "unk/OTHER"
    long_tokens, n = pad_caption([f"w{i}/NOUN" for i in range(30)])
    assert n == 22 and long_tokens[-1] == "eos/OTHER" and long_tokens[-2] == "w19/NOUN"


CAPTIONS = [["a/DET", "person/NOUN", "walk/VERB", "left/ADV"], ["someone/PRON", "jump/VERB"]]


def test_caption_vocabulary_and_learned_embedding():
    vocab = CaptionVocabulary.build(CAPTIONS)
    assert vocab.words[:3] == ["sos", "eos", "unk"] and len(vocab) == 3 + 6
    enc = vocab.encode([["a/DET", "zebra/NOUN"]])
    assert enc.words.shape == (1, 22) and enc.pos_onehot.shape == (1, 22, 15) and enc.lengths.tolist() == [4]
    assert enc.words[0, :4].tolist() == [0, vocab.index["a"], 2, 1]  # sos, a, unk (zebra), eos
    assert POS_CATEGORIES[int(enc.pos_onehot[0, 2].argmax())] == "OTHER"  # unknown word -> OTHER
    emb = LearnedWordEmbedding(len(vocab), 300, generator=torch.Generator().manual_seed(0))
    model = tiny_model()
    out = model.encode_text(emb(enc.words), enc.pos_onehot, enc.lengths)
    out.sum().backward()  # trains end to end
    assert emb.embedding.weight.grad is not None and out.shape == (1, TINY.dim_coemb)
    with pytest.raises(ValueError, match="word/POS"):
        CaptionVocabulary.build([["nopos"]])


# --- official loader --------------------------------------------------------------------------------------

GLOVE_WORDS = ["sos", "eos", "unk", "a", "person", "walk", "left"]  # what tests/conftest.py writes


@pytest.fixture
def write_official_layout(official_evaluator_layout):
    """``write(root, dataset="t2m", model=None)``: the downloaded layout with ``tiny_model(1)`` unless told."""

    def write(root, dataset="t2m", model=None):
        model = model or tiny_model(1)
        official_evaluator_layout(root, model, dataset)
        return model

    return write


def test_load_official_evaluator_round_trip(tmp_path, write_official_layout):
    saved = write_official_layout(tmp_path)
    ev = load_official_evaluator(tmp_path / "checkpoints", tmp_path / "glove")
    assert ev.epoch == 7 and ev.model.config == TINY and not ev.model.training
    for k, v in saved.state_dict().items():
        assert torch.equal(ev.model.state_dict()[k], v), k
    assert load_official_evaluator(tmp_path, tmp_path).epoch == 7  # parents of both folders work too

    # GloVe lookup: known word, unknown word -> unk vector and OTHER
    vecs = np.load(tmp_path / "glove" / "our_vab_data.npy")
    vec, onehot = ev.words["walk/VERB"]
    np.testing.assert_array_equal(vec, vecs[5])
    assert POS_CATEGORIES[int(onehot.argmax())] == "Act_VIP"
    vec, onehot = ev.words["zebra/NOUN"]
    np.testing.assert_array_equal(vec, vecs[2])
    assert POS_CATEGORIES[int(onehot.argmax())] == "OTHER"

    # embedding helpers equal the manual path (normalise, zero the padding, encode)
    text = ev.embed_captions(CAPTIONS)
    enc = WordVectorizer(tmp_path / "glove").encode(CAPTIONS)
    with torch.no_grad():
        torch.testing.assert_close(text, saved.encode_text(enc.words, enc.pos_onehot, enc.lengths))
    raw = torch.randn(2, 16, 263, generator=torch.Generator().manual_seed(2))
    lengths = torch.tensor([16, 8])
    norm = ev.normalizer.normalize(raw)
    norm[1, 8:] = 0.0
    with torch.no_grad():
        torch.testing.assert_close(ev.embed_batch(raw, lengths), saved.encode_motion(norm, lengths))


def test_load_official_evaluator_names_missing_files(tmp_path, write_official_layout):
    write_official_layout(tmp_path)
    (tmp_path / "glove" / "our_vab_data.npy").unlink()
    (tmp_path / "checkpoints" / "t2m" / "Comp_v6_KLD005" / "meta" / "std.npy").unlink()
    with pytest.raises(FileNotFoundError) as err:
        load_official_evaluator(tmp_path / "checkpoints", tmp_path / "glove")
    assert "our_vab_data.npy" in str(err.value) and "std.npy" in str(err.value)
    with pytest.raises(FileNotFoundError, match="finest.tar"):
        load_official_evaluator(tmp_path / "checkpoints", tmp_path / "glove", dataset="kit")


def test_load_official_evaluator_checks_the_feature_size(tmp_path, write_official_layout):
    small = dict(dim_text_hidden=4, dim_motion_hidden=4, dim_coemb=4, dim_movement_hidden=4, dim_movement_latent=4)
    kit_model = TextMotionEvaluator(EvaluatorConfig(dim_pose=251, **small))
    write_official_layout(tmp_path, "t2m", kit_model)  # a KIT-sized network where t2m is expected
    with pytest.raises(ValueError, match="251-d features"):
        load_official_evaluator(tmp_path, tmp_path)


# --- the official evaluation path --------------------------------------------------------------------------


def official_embeddings(model: TextMotionEvaluator, clips: list[torch.Tensor], mean=0.0, std=1.0) -> torch.Tensor:
    """Each clip's embedding as MoMask / text-to-motion compute it, written from their code, not motionlab's batching.

    ``Text2MotionDatasetEval``: crop a clip to ``len // 4 * 4`` frames (from frame 0 here; they draw a random
    start), normalise, zero-pad to exactly 196 frames. ``EvaluatorModelWrapper.get_co_embeddings``: sort the
    batch by length, descending; the movement encoder (Conv1d k4 s2 p1 + LeakyReLU 0.2, twice, then Linear)
    over all 196 frames; the motion GRU packed by ``length // 4``. Embeddings come back in the clips' order.
    """
    lengths = torch.tensor([len(c) // 4 * 4 for c in clips])
    window = [torch.cat([(c[:n] - mean) / std, c.new_zeros(196 - n, c.shape[1])]) for c, n in zip(clips, lengths)]
    order = torch.argsort(lengths, descending=True, stable=True)
    motions, lengths = torch.stack(window).float()[order], lengths[order]
    conv = model.movement_encoder.state_dict()
    h = motions[..., :-4].transpose(1, 2)  # (B, D-4, 196)
    for layer in ("main.0", "main.3"):
        h = F.leaky_relu(F.conv1d(h, conv[f"{layer}.weight"], conv[f"{layer}.bias"], stride=2, padding=1), 0.2)
    movements = F.linear(h.transpose(1, 2), conv["out_net.weight"], conv["out_net.bias"])  # (B, 49, latent)
    enc = model.motion_encoder
    packed = pack_padded_sequence(enc.input_emb(movements), (lengths // 4).tolist(), batch_first=True)
    _, last = enc.gru(packed, enc.hidden.repeat(1, len(clips), 1))
    return enc.output_net(torch.cat((last[0], last[1]), dim=-1))[torch.argsort(order)]


def padded(clips: list[torch.Tensor], width: int, fill: float = float("nan")) -> torch.Tensor:
    """Clips in a ``(B, width, D)`` batch; ``fill`` past each clip's end (NaN: fails loudly if ever read)."""
    out = torch.full((len(clips), width, clips[0].shape[1]), fill)
    for i, c in enumerate(clips):
        out[i, : len(c)] = c
    return out


@pytest.mark.parametrize(
    "lengths, width",
    [
        (list(range(4, 200)), 199),  # every length the official loaders keep, 197-199 floored to 196
        ([36, 60, 84, 108, 132, 156, 180, 196], 196),  # multiples of 4, a 196-frame clip among them
        ([196], 196),
        ([193, 194, 195, 196], 196),
        ([193, 194, 195, 196], 250),
        ([188, 192], 192),  # narrower than the 194 frames a 192-frame clip needs: padded here
        ([36], 36),
        ([36], 37),
        ([37, 38, 39, 36], 50),  # floored to 36
        ([4, 5, 6, 7, 8, 12], 12),
        ([4, 40, 41, 77], 196),
        ([36, 60], 60),  # a short clip beside a longer one
    ],
)
def test_motion_embedding_is_the_official_one(lengths, width):
    model = tiny_model(3)
    g = torch.Generator().manual_seed(len(lengths) + width)
    clips = [torch.randn(n, TINY.dim_pose, generator=g) for n in lengths]
    with torch.no_grad():
        ours = model.encode_motion(padded(clips, width), torch.tensor(lengths))
        torch.testing.assert_close(ours, official_embeddings(model, clips), rtol=0, atol=1e-5)


def test_every_length_alone_embeds_as_in_the_official_batch():
    model = tiny_model(4)
    g = torch.Generator().manual_seed(0)
    clips = [torch.randn(n, TINY.dim_pose, generator=g) for n in range(4, 200)]
    with torch.no_grad():
        official = official_embeddings(model, clips)
        alone = torch.cat([model.encode_motion(c[None], torch.tensor([len(c)])) for c in clips])
    torch.testing.assert_close(alone, official, rtol=0, atol=1e-5)


def test_official_evaluator_embeds_raw_features_as_the_official_loader(tmp_path, write_official_layout):
    write_official_layout(tmp_path)
    ev = load_official_evaluator(tmp_path, tmp_path)
    g = torch.Generator().manual_seed(1)
    clips = [torch.randn(n, 263, generator=g) for n in (196, 40, 197, 123, 194)]
    meta = tmp_path / "checkpoints" / "t2m" / "Comp_v6_KLD005" / "meta"
    mean, std = (torch.as_tensor(np.load(meta / f)) for f in ("mean.npy", "std.npy"))
    with torch.no_grad():
        expected = official_embeddings(ev.model, clips, mean, std)
    torch.testing.assert_close(
        ev.embed_batch(padded(clips, 197, 0.0), [len(c) for c in clips]), expected, rtol=0, atol=1e-5
    )


def test_official_evaluator_embeds_a_list_of_clips_like_every_evaluator(tmp_path, write_official_layout):
    write_official_layout(tmp_path)
    ev = load_official_evaluator(tmp_path, tmp_path)
    g = torch.Generator().manual_seed(2)
    clips = [torch.randn(n, 263, generator=g).numpy() for n in (196, 40, 123, 41, 8)]
    whole = ev.embed_batch(padded([torch.as_tensor(c) for c in clips], 196, 0.0), [len(c) for c in clips]).numpy()
    np.testing.assert_allclose(ev.embed_motions(clips, batch_size=2), whole, rtol=0, atol=1e-5)  # order kept
    with pytest.raises(ValueError, match="non-empty list"):
        ev.embed_motions(np.zeros((40, 263)))
    with pytest.raises(ValueError, match=r"\(T, 263\)"):
        ev.embed_motions([np.zeros((40, 251))])


def test_official_motion_batch_crops_zeroes_and_pads():
    x = torch.ones(2, 10, 3)
    out, lengths = official_motion_batch(x, torch.tensor([10, 7]))
    assert lengths.tolist() == [8, 4] and out.shape == (2, 10, 3)  # max(8, 4) + 2 frames
    assert out[0, :8].eq(1).all() and out[0, 8:].eq(0).all() and out[1, :4].eq(1).all() and out[1, 4:].eq(0).all()
    # short batches stay short (as fast as they can be); with a 196-frame clip, the official 196-frame window
    for lengths, frames in (([40], 42), ([192], 194), ([195], 194), ([196, 40], 196), ([199], 196)):
        out, _ = official_motion_batch(torch.ones(1, 199, 3).expand(len(lengths), -1, -1), torch.tensor(lengths))
        assert out.shape[1] == frames, lengths
    for bad in (1, 2, 3, 200):  # no movement step; a clip the official loaders drop
        with pytest.raises(ValueError, match="unit_length=4 frames and at most 196"):
            official_motion_batch(torch.ones(1, 200, 3), torch.tensor([bad]))
