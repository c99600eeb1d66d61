"""How to read each attention plot, in one line: declared once here, beside the plot functions, and shown under
the plot wherever it is drawn (the studio's tabs put it under their figure: ``app.components.how_to_read``).

Keys name the plots: the cross-attention word curves, the self-attention map and its picked row, the Q/K cluster
strips, the correspondences, the Q/K attention maps, the per-query maps and the counting map. No import here
loads a plotting library."""
from __future__ import annotations

HOW_TO_READ: dict[str, str] = {
    "word_curves": "x: frame · y: the share of attention on each word. A word's peak marks the frames that act it "
                   "out; a flat curve, a word the motion barely reads.",
    "self_attention": "Row: a query frame · column: the key frames it reads. Bright = strong attention. The "
                      "diagonal is \"now\"; stripes beside it repeat a movement; red dots: the counting peaks.",
    "attention_row": "The picked frame's row of the map: each peak is a frame that frame draws on.",
    "qk_clusters": "One cell per frame, coloured by its Q cluster (left) or K cluster (right). The same colour in "
                   "leader and follower = frames that play the same part of the movement.",
    "correspondences": "Each leader frame with its nearest follower frame (argmax of Q leader · K follower). "
                       "Bottom row: the leader redrawn from those frames; jumps back = a reused motif.",
    "qk_maps": "Row: query frame · column: key frame · bright = strong attention. Mixed: a bright path from top "
               "left to bottom right = the follower frames each leader frame borrows, in order.",
    "per_query": "The picked leader frame's attention over the leader's own frames (blue) and the follower's "
                 "(orange). A peak = the frame it borrows most from.",
    "counting": "Self-attention without its diagonal band, normalised. Bright stripes parallel to the diagonal = "
                "a repeated movement; their spacing is the period, the red peaks count the repeats.",
}


def how_to_read(plot: str) -> str:
    """The one-line reading of ``plot`` (a key of :data:`HOW_TO_READ`)."""
    return HOW_TO_READ[plot]
