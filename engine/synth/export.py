"""Write a HumanML3D-layout folder from the corpus, plus ``labels/NAME.json``."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from engine.representation import Normalizer
from engine.synth.corpus import Corpus
from engine.synth.grammar import tokens, words


def _writer():
    try:
        from engine.io.humanml3d import Caption, write_sample, write_split
    except ImportError:  # pragma: no cover - the io module is part of the project
        return None
    return Caption, write_sample, write_split


def export_corpus(out: str | Path, *, n: int, seed: int = 0, split: str = "train", progress=None) -> Path:
    """Write ``n`` samples of ``split`` to ``out``: new_joint_vecs/, new_joints/, texts/,
    labels/, Mean.npy, Std.npy and ``<split>.txt`` + ``all.txt`` name lists."""
    out = Path(out)
    (out / "labels").mkdir(parents=True, exist_ok=True)
    corpus = Corpus(split, seed=seed)
    io = _writer()
    names, feats = [], []
    for i in range(n):
        s = corpus.sample(i)
        name = f"{split}_{i:06d}"
        caps = [c for c in s.captions if words(c)]
        if io is not None:
            Caption, write_sample, _ = io
            write_sample(out, name, s.features, s.joints,
                         [Caption(text=c, tokens=tuple(tokens(c).split())) for c in caps])
        else:  # minimal private writer
            for sub in ("new_joint_vecs", "new_joints", "texts"):
                (out / sub).mkdir(parents=True, exist_ok=True)
            np.save(out / "new_joint_vecs" / f"{name}.npy", s.features)
            np.save(out / "new_joints" / f"{name}.npy", s.joints)
            (out / "texts" / f"{name}.txt").write_text("".join(f"{c}#{tokens(c)}#0.0#0.0\n" for c in caps))
        label = s.labels.to_json()
        label["program"] = s.program.to_json()
        label["captions"] = caps
        (out / "labels" / f"{name}.json").write_text(json.dumps(label))
        names.append(name)
        feats.append(s.features)
        if progress is not None:
            progress(1)
    norm = Normalizer.fit(np.concatenate(feats, 0))
    norm.save(out)
    if io is not None:
        io[2](out, split, names)
        io[2](out, "all", names)
    else:
        (out / f"{split}.txt").write_text("".join(f"{nm}\n" for nm in names))
        (out / "all.txt").write_text("".join(f"{nm}\n" for nm in names))
    return out
