"""MoMo's analysis of self-attention: Q-vs-K clusters, nearest-neighbour correspondences, maps.

Sites are given as (layer, step) of the sampling loop. The paper's sites (12 layers, 100
steps: clusters at layer 11 and t = 30, correspondences at layer 10 and t = 50, full maps at
layer 6 and t = 70) are mapped onto the model at hand by :func:`paper_site`.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import torch
from einops import rearrange
from sklearn.cluster import KMeans
from sklearn.decomposition import PCA

from engine.attention import AttentionStore, StoreConfig
from engine.checkpoint import LoadedModel
from engine.generate import Request, SampleConfig, frames_for, sample_states

PAPER_LAYERS, PAPER_STEPS = 12, 100


def qk_record(*, steps: Sequence[int] | None = None, layers: Sequence[int] | None = None) -> StoreConfig:
    """What the analysis views need: self-attention Q and K (and V) of the conditional slots."""
    return StoreConfig(kinds=("self",), record_probs=False, record_qkv=True,
                       steps=None if steps is None else frozenset(steps),
                       layers=None if layers is None else frozenset(layers), budget_bytes=768 * 1024 * 1024)


@dataclass(frozen=True)
class Site:
    layer: int  # 0-based block
    step: int  # index in the sampling loop, 0 = noisiest


def paper_site(*, layer: int, t: int, n_layers: int, n_steps: int) -> Site:
    """The paper's 1-based layer of 12 and timestep of 100 -> a 0-based layer and loop step here."""
    lay = int(np.clip(round(layer / PAPER_LAYERS * n_layers) - 1, 0, n_layers - 1))
    step = int(np.clip(round((1 - t / PAPER_STEPS) * n_steps), 0, n_steps - 1))
    return Site(layer=lay, step=step)


def cluster_site(n_layers: int, n_steps: int) -> Site:
    return paper_site(layer=11, t=30, n_layers=n_layers, n_steps=n_steps)


def correspondence_site(n_layers: int, n_steps: int) -> Site:
    return paper_site(layer=10, t=50, n_layers=n_layers, n_steps=n_steps)


def maps_site(n_layers: int, n_steps: int) -> Site:
    return paper_site(layer=6, t=70, n_layers=n_layers, n_steps=n_steps)


def qk_at(store: AttentionStore, site: Site, *, slot: int, frames: int) -> tuple[np.ndarray, np.ndarray]:
    """Q and K of one slot at a site, heads concatenated: (frames, width) each."""
    rec = store.get(step=site.step, layer=site.layer, kind="self")
    if rec.q is None or rec.k is None:
        raise KeyError("Q and K were not recorded (record_qkv=False)")
    q = rearrange(rec.q[slot, :, :frames].float(), "h n d -> n (h d)").numpy()
    k = rearrange(rec.k[slot, :, :frames].float(), "h n d -> n (h d)").numpy()
    return q, k


def heads_of(store: AttentionStore, site: Site) -> int:
    return int(store.get(step=site.step, layer=site.layer, kind="self").q.shape[1])


# ----------------------------------------------------------------------------- clusters
@dataclass(frozen=True)
class ClusterConfig:
    """PCA to ``components`` dims, then K-Means into ``clusters`` (paper: d = 10, m = 10)."""

    components: int = 10
    clusters: int = 10
    seed: int = 0


@dataclass
class QKClusters:
    """PCA + K-Means fitted separately on Q and on K of one site."""

    site: Site
    config: ClusterConfig
    pca_q: PCA
    kmeans_q: KMeans
    pca_k: PCA
    kmeans_k: KMeans
    fitted_frames: int

    def labels(self, q: np.ndarray, k: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Cluster index per frame for Q and for K: (N,), (N,)."""
        return (self.kmeans_q.predict(self.pca_q.transform(q)).astype(int),
                self.kmeans_k.predict(self.pca_k.transform(k)).astype(int))


def fit(q: np.ndarray, k: np.ndarray, *, site: Site, config: ClusterConfig = ClusterConfig()) -> QKClusters:
    """Fit on stacked frames (F, width) of Q and of K."""
    need = max(config.components, config.clusters)
    if len(q) < need:
        raise ValueError(f"fitting {config.clusters} clusters in {config.components} dims needs at least {need} frames")
    parts = []
    for x in (q, k):
        pca = PCA(n_components=config.components, random_state=config.seed).fit(x)
        km = KMeans(n_clusters=config.clusters, n_init=4, random_state=config.seed).fit(pca.transform(x))
        parts += [pca, km]
    return QKClusters(site=site, config=config, pca_q=parts[0], kmeans_q=parts[1], pca_k=parts[2], kmeans_k=parts[3],
                      fitted_frames=len(q))


def collect_qk(loaded: LoadedModel, prompts: Sequence[str], *, site: Site, sample: SampleConfig = SampleConfig(),
               seconds: float = 5.0, per_prompt: int = 2, batch: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """Q and K at ``site`` of generated motions (``per_prompt`` seeds each), stacked over frames.

    Sampling stops at the site's step: later steps do not change what was recorded.
    """
    frames = frames_for(seconds)
    items = [p for p in prompts for _ in range(per_prompt)]
    if not items:
        raise ValueError("give at least one prompt to fit the clusters on")
    qs, ks = [], []
    for start in range(0, len(items), batch):
        chunk = items[start : start + batch]
        store = AttentionStore(qk_record(steps=[site.step], layers=[site.layer]))
        config = SampleConfig(steps=sample.steps, guidance=sample.guidance, seed=sample.seed + start)
        states, *_ = sample_states(loaded, Request(prompts=chunk, frames=[frames] * len(chunk)), config,
                                   controller=store)
        for state in states:
            if state.step >= site.step:
                break
        for slot in range(len(chunk)):
            q, k = qk_at(store, site, slot=slot, frames=frames)
            qs.append(q)
            ks.append(k)
    return np.concatenate(qs), np.concatenate(ks)


def fit_clusters(loaded: LoadedModel, prompts: Sequence[str], *, site: Site, sample: SampleConfig = SampleConfig(),
                 config: ClusterConfig = ClusterConfig(), seconds: float = 5.0, per_prompt: int = 2) -> QKClusters:
    """The paper fits on 256 motions from 128 prompts; any number works (see ``per_prompt``)."""
    q, k = collect_qk(loaded, prompts, site=site, sample=sample, seconds=seconds, per_prompt=per_prompt)
    return fit(q, k, site=site, config=config)


# ----------------------------------------------------------------------------- correspondences and maps
def nearest_keys(q: np.ndarray, k: np.ndarray) -> np.ndarray:
    """For each query frame (N, width) the key frame (of M) with the largest q . k: (N,) indices.

    The head-summed dot product (the concatenated vectors) ranks keys like the head-averaged score.
    """
    return np.argmax(q @ k.T, axis=1).astype(int)


def attention_map(q: np.ndarray, k: np.ndarray, *, heads: int) -> np.ndarray:
    """softmax(q_h k_hᵀ / √dh) averaged over heads: (N, M), rows sum to 1."""
    qh = torch.from_numpy(rearrange(q, "n (h d) -> h n d", h=heads))
    kh = torch.from_numpy(rearrange(k, "m (h d) -> h m d", h=heads))
    scores = qh @ kh.transpose(-1, -2) / qh.shape[-1] ** 0.5
    return scores.softmax(-1).mean(0).numpy()


# ----------------------------------------------------------------------------- one transfer, analysed
FIT_PROMPTS = (
    "a person walks forward", "a person runs forward", "a person jumps twice", "a person dances",
    "a person walks like a zombie", "a person walks like a chicken", "a person jogs in a circle",
    "a person steps sideways to the left", "a person walks backwards", "a person hops on one foot",
    "a person does jumping jacks", "a person squats", "a person kicks with the right leg",
    "a person waves the right hand", "a person walks like an old man", "a person walks proudly",
)


@dataclass
class TransferAnalysis:
    """Everything the analysis views show for one transfer (frames = each stream's own length).

    ``q_labels`` / ``k_labels``: role -> cluster per frame (Q and K at the cluster site);
    ``nearest``: per leader frame, the follower frame with the largest q_leader . k_follower
    (correspondence site); ``maps``: name -> (N, M) head-averaged attention at the maps site
    ("leader", "follower" self-attention and the "mixed" map softmax(Q_leader K_followerᵀ)).
    """

    cluster_site: Site
    correspondence_site: Site
    maps_site: Site
    q_labels: dict[str, np.ndarray]
    k_labels: dict[str, np.ndarray]
    nearest: np.ndarray
    maps: dict[str, np.ndarray]

    def per_query(self, frame: int) -> dict[str, np.ndarray]:
        """Rows of the leader's own map and of the mixed map for one leader frame (MoMo's Fig. 5)."""
        if not 0 <= frame < len(self.maps["leader"]):
            raise IndexError(f"leader frame {frame} is outside 0..{len(self.maps['leader']) - 1}")
        return {"leader": self.maps["leader"][frame], "mixed": self.maps["mixed"][frame]}

    def to_json(self) -> dict:
        return {
            "cluster_site": vars(self.cluster_site), "correspondence_site": vars(self.correspondence_site),
            "maps_site": vars(self.maps_site),
            "q_labels": {k: v.tolist() for k, v in self.q_labels.items()},
            "k_labels": {k: v.tolist() for k, v in self.k_labels.items()},
            "nearest": self.nearest.tolist(),
        }


def analysis_sites(n_layers: int, n_steps: int) -> tuple[Site, Site, Site]:
    return cluster_site(n_layers, n_steps), correspondence_site(n_layers, n_steps), maps_site(n_layers, n_steps)


def analyze_transfer(store: AttentionStore, *, frames: dict[str, int], slots: dict[str, int], clusters: QKClusters,
                     correspondence: Site, maps: Site) -> TransferAnalysis:
    """``frames`` / ``slots``: role ("leader", "follower", "out") -> length and batch slot."""
    q_labels, k_labels = {}, {}
    for role, slot in slots.items():
        q, k = qk_at(store, clusters.site, slot=slot, frames=frames[role])
        q_labels[role], k_labels[role] = clusters.labels(q, k)
    ql, _ = qk_at(store, correspondence, slot=slots["leader"], frames=frames["leader"])
    _, kf = qk_at(store, correspondence, slot=slots["follower"], frames=frames["follower"])
    nearest = nearest_keys(ql, kf)
    heads = heads_of(store, maps)
    ql, kl = qk_at(store, maps, slot=slots["leader"], frames=frames["leader"])
    qf, kf = qk_at(store, maps, slot=slots["follower"], frames=frames["follower"])
    maps_out = {"leader": attention_map(ql, kl, heads=heads), "follower": attention_map(qf, kf, heads=heads),
                "mixed": attention_map(ql, kf, heads=heads)}
    return TransferAnalysis(cluster_site=clusters.site, correspondence_site=correspondence, maps_site=maps,
                            q_labels=q_labels, k_labels=k_labels, nearest=nearest, maps=maps_out)
