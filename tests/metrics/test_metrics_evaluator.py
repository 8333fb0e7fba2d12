"""The text-motion evaluator: checkpoint compatibility, caller order, words, loss and the official loader."""

import pickle

import numpy as np
import pytest
import torch

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

# The compatibility contract: parameter names and shapes of the official t2m ``finest.tar``
# (EricGuo5513/text-to-motion, networks/modules.py with the sizes of EvaluatorModelWrapper).
GRU_KEYS = ["weight_ih_l0", "weight_hh_l0", "bias_ih_l0", "bias_hh_l0"]


def _gru(h: int, d: int) -> dict:
    shapes = {"weight_ih_l0": (3 * h, d), "weight_hh_l0": (3 * h, h), "bias_ih_l0": (3 * h,), "bias_hh_l0": (3 * h,)}
    out = {f"gru.{k}": v for k, v in shapes.items()}
    out.update({f"gru.{k}_reverse": v for k, v in shapes.items()})
    return out


def _head(h: int, out: int) -> dict:
    return {"output_net.0.weight": (h, 2 * h), "output_net.0.bias": (h,), "output_net.1.weight": (h,),
            "output_net.1.bias": (h,), "output_net.3.weight": (out, h), "output_net.3.bias": (out,)}  # fmt: skip


OFFICIAL_T2M = {
    "movement_encoder": {"main.0.weight": (512, 259, 4), "main.0.bias": (512,), "main.3.weight": (512, 512, 4),
                         "main.3.bias": (512,), "out_net.weight": (512, 512), "out_net.bias": (512,)},
    "text_encoder": {"pos_emb.weight": (300, 15), "pos_emb.bias": (300,), "input_emb.weight": (512, 300),
                     "input_emb.bias": (512,), "hidden": (2, 1, 512), **_gru(512, 512), **_head(512, 512)},
    "motion_encoder": {"input_emb.weight": (1024, 512), "input_emb.bias": (1024,), "hidden": (2, 1, 1024),
                       **_gru(1024, 1024), **_head(1024, 512)},
}  # fmt: skip

TINY = EvaluatorConfig(dim_text_hidden=8, dim_motion_hidden=12, dim_coemb=6, dim_movement_hidden=10,
                       dim_movement_latent=10)  # fmt: skip


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

GLOVE_WORDS = ["sos", "eos", "unk", "a", "person", "walk", "left"]


def write_official_layout(root, dataset="t2m", model=None):
    """The downloaded layout, with tiny random weights of the official key set and GloVe of 7 words."""
    model = model or tiny_model(1)
    ckpt_dir = root / "checkpoints" / dataset / "text_mot_match" / "model"
    meta = root / "checkpoints" / dataset / "Comp_v6_KLD005" / "meta"
    glove = root / "glove"
    for d in (ckpt_dir, meta, glove):
        d.mkdir(parents=True)
    torch.save({**model.official_state(), "epoch": 7}, ckpt_dir / "finest.tar")
    rng = np.random.default_rng(0)
    np.save(meta / "mean.npy", rng.normal(size=263).astype(np.float32))
    np.save(meta / "std.npy", rng.uniform(0.5, 2, size=263).astype(np.float32))
    np.save(glove / "our_vab_data.npy", rng.normal(size=(len(GLOVE_WORDS), 300)).astype(np.float32))
    with open(glove / "our_vab_words.pkl", "wb") as f:
        pickle.dump(GLOVE_WORDS, f)
    with open(glove / "our_vab_idx.pkl", "wb") as f:
        pickle.dump({w: i for i, w in enumerate(GLOVE_WORDS)}, f)
    return model


def test_load_official_evaluator_round_trip(tmp_path):
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
        torch.testing.assert_close(ev.embed_motions(raw, lengths), saved.encode_motion(norm, lengths))


def test_load_official_evaluator_names_missing_files(tmp_path):
    write_official_layout(tmp_path)
    (tmp_path / "glove" / "our_vab_data.npy").unlink()
    (tmp_path / "checkpoints" / "t2m" / "Comp_v6_KLD005" / "meta" / "std.npy").unlink()
    with pytest.raises(FileNotFoundError) as err:
        load_official_evaluator(tmp_path / "checkpoints", tmp_path / "glove")
    assert "our_vab_data.npy" in str(err.value) and "std.npy" in str(err.value)
    with pytest.raises(FileNotFoundError, match="finest.tar"):
        load_official_evaluator(tmp_path / "checkpoints", tmp_path / "glove", dataset="kit")


def test_load_official_evaluator_checks_the_feature_size(tmp_path):
    small = dict(dim_text_hidden=4, dim_motion_hidden=4, dim_coemb=4, dim_movement_hidden=4, dim_movement_latent=4)
    kit_model = TextMotionEvaluator(EvaluatorConfig(dim_pose=251, **small))
    write_official_layout(tmp_path, "t2m", kit_model)  # a KIT-sized network where t2m is expected
    with pytest.raises(ValueError, match="251-d features"):
        load_official_evaluator(tmp_path, tmp_path)


def test_motion_embedding_does_not_depend_on_the_callers_padding():
    # The movement encoder's last step for a clip of L frames reads frames L-1 .. L+2: a batch padded to
    # only L or L+1 frames used to replace that step's input by the convolution's zero padding.
    model = tiny_model(3)
    clip = torch.randn(40, TINY.dim_pose, generator=torch.Generator().manual_seed(4))

    def embed(padded_to: int, fill: float = 0.0, length: int = 36) -> torch.Tensor:
        x = torch.full((1, padded_to, TINY.dim_pose), fill)
        x[0, :length] = clip[:length]
        with torch.no_grad():
            return model.encode_motion(x, torch.tensor([length]))[0]

    official = embed(196)
    for padded_to in (36, 37, 38, 50):
        torch.testing.assert_close(embed(padded_to), official, rtol=0, atol=1e-6)
    torch.testing.assert_close(embed(40, fill=float("nan")), official, rtol=0, atol=1e-6)  # padding is never read
    # a length that is not a multiple of 4 is cropped the official way: its first floor(L/4)*4 frames
    for length in (37, 38, 39):
        torch.testing.assert_close(embed(196, length=length, fill=7.0), embed(36, length=36), rtol=0, atol=1e-6)
    # in a batch: the short clip's embedding is the same beside a longer one and alone
    batch = torch.zeros(2, 60, TINY.dim_pose)
    batch[0, :36] = clip[:36]
    batch[1] = torch.randn(60, TINY.dim_pose, generator=torch.Generator().manual_seed(5))
    with torch.no_grad():
        together = model.encode_motion(batch, torch.tensor([36, 60]))
    torch.testing.assert_close(together[0], official, rtol=0, atol=1e-6)


def test_official_motion_batch_crops_zeroes_and_pads():
    from motionlab.metrics.evaluator import official_motion_batch

    x = torch.ones(2, 10, 3)
    out, lengths = official_motion_batch(x, torch.tensor([10, 7]))
    assert lengths.tolist() == [8, 4] and out.shape == (2, 10, 3)  # max(8, 4) + 2 frames
    assert out[0, :8].eq(1).all() and out[0, 8:].eq(0).all() and out[1, :4].eq(1).all() and out[1, 4:].eq(0).all()
    out, _ = official_motion_batch(torch.ones(1, 196, 3), torch.tensor([40]))
    assert out.shape == (1, 42, 3)  # the official 196 frames of padding, cut to what the encoder reads
