"""Captions: a small grammar with synonyms and varied word order, and the finite vocabulary.

Every caption is built from the phrase tables below, so :func:`vocabulary` (all words any
caption of any split can contain, lowercase, punctuation stripped) is exact by construction;
``tests/test_synth_grammar.py`` checks it against generated captions and the file
``vocabulary.txt``. Templates marked held out appear only in the ``ood`` split.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from engine.synth.program import Program, Segment

SUBJECTS = (
    "a person", "someone", "a man", "a woman", "the person", "a human", "the man", "the woman",
    "he", "she", "somebody", "a guy", "a lady", "a boy", "a girl", "a kid", "a child", "an adult",
    "an athlete", "a dancer", "a figure", "a character", "the athlete", "the actor", "a player", "an individual",
    "the individual", "a performer", "a young man", "a young woman", "a teenager", "a gentleman", "a fellow",
    "the subject", "an avatar", "the avatar", "a stick figure", "the character", "the figure", "this person",
    "a model", "a student", "my friend", "a dude", "a lad", "a teen", "the guy", "the lady", "the boy", "the girl",
    "the kid", "an actor", "an actress",
)
COUNT_WORDS = {1: ("once", "one time", "a single time", "just once", "one single time"),
               2: ("twice", "two times", "a couple of times", "a couple times", "two times in a row"),
               3: ("three times", "thrice", "three times in a row", "a few times", "repeatedly"),
               4: ("four times", "four times in a row", "several times", "repeatedly"),
               5: ("five times", "five times in a row", "several times", "repeatedly", "over and over")}
COUNT_NUMBERS = {1: "one", 2: "two", 3: "three", 4: "four", 5: "five"}
# "does three squats": (singular, plural, (third, gerund) verbs); count 1 says "a single" / "one"
COUNT_NOUNS = {
    "jump": ("jump", "jumps", (("does", "doing"), ("makes", "making"))),
    "jump_forward": ("forward jump", "forward jumps", (("does", "doing"), ("makes", "making"))),
    "hop": ("hop", "hops", (("does", "doing"), ("takes", "taking"))),
    "squat": ("squat", "squats", (("does", "doing"), ("performs", "performing"))),
    "kick": ("kick", "kicks", (("does", "doing"), ("throws", "throwing"), ("delivers", "delivering"))),
    "punch": ("punch", "punches", (("throws", "throwing"), ("does", "doing"), ("delivers", "delivering"))),
    "bow": ("bow", "bows", (("does", "doing"), ("makes", "making"))),
    "clap": ("clap", "claps", (("gives", "giving"), ("does", "doing"))),
}
SINGLE = ("a single", "one", "just one")
SPEED_WORDS = {"slowly": ("slowly", "at a slow pace", "leisurely", "unhurriedly", "calmly", "at an easy pace",
                          "in slow motion", "without hurrying", "lazily", "at a relaxed pace", "sluggishly",
                          "very slowly", "deliberately"),
               "quickly": ("quickly", "fast", "rapidly", "at a fast pace", "briskly", "hurriedly", "swiftly",
                           "speedily", "at high speed", "in a hurry", "at a quick pace", "hastily", "very fast",
                           "really quickly", "at a rapid pace", "in a rush", "with haste")}
STYLE_PHRASES = {
    "zombie": ("like a zombie", "as a zombie", "in a zombie way", "with the arms stretched forward like a zombie",
               "with outstretched arms like a zombie", "like the undead", "zombie style", "like a walking corpse",
               "with both arms held out in front",
               "lifelessly", "shambling", "like a mummy", "like a sleepwalker"),
    "chicken": ("like a chicken", "as a chicken", "flapping the arms like a chicken", "like a hen", "like a rooster",
                "like a bird", "with the elbows flapping like wings", "in a chicken style", "flapping its elbows"),
    "hands_up": ("with hands up", "with both hands raised", "with the arms up in the air", "holding the hands up",
                 "with the hands above the head", "with the arms over the head", "with both arms overhead",
                 "with the hands in the air", "with raised arms", "as if surrendering", "with the hands held high",
                 "with arms raised high", "with both hands up above the head"),
    "crouched": ("sneakily", "in a crouch", "stealthily", "while crouching low", "in a sneaky way", "like a ninja",
                 "like a thief", "furtively", "cautiously", "bent low", "staying low", "hunched down",
                 "with bent knees", "like a spy", "quietly",
                 "like a prowler", "prowling"),
    "old": ("like an old man", "like an elderly person", "tiredly", "wearily", "like an old woman", "like a grandpa",
            "like a grandma", "feebly", "frailly", "with a stoop", "stooped over", "like a senior citizen",
            "like an elderly man", "exhaustedly", "with a hunched back", "like an aged person",
            "shuffling like an old man", "haltingly"),
    "happy": ("happily", "cheerfully", "joyfully", "in a happy way", "excitedly", "gleefully", "merrily",
              "in a good mood", "bouncily", "playfully", "with joy", "in an upbeat way", "cheerily",
              "like a happy person", "in a cheerful mood", "with glee", "joyously",
              "elatedly", "with a bounce"),
    "sad": ("sadly", "gloomily", "in a sad way", "dejectedly", "miserably", "sorrowfully", "unhappily", "glumly",
            "with the head down", "with a hung head", "in a depressed way", "mournfully", "sulkily",
            "with drooping shoulders", "like a sad person", "with slumped shoulders",
            "downheartedly", "despondently", "with a heavy heart"),
    "robot": ("like a robot", "robotically", "mechanically", "stiffly", "in a robotic way", "like a machine",
              "like an android", "like a droid", "rigidly", "jerkily", "in a mechanical way", "with robotic movements",
              "like a cyborg", "in stiff jerky motions"),
    "drunk": ("like a drunk person", "drunkenly", "unsteadily", "like a drunk", "staggering", "tipsily",
              "like a drunkard", "while drunk", "wobbling", "swaying unsteadily", "in a drunken way", "wobbly",
              "like someone who had too much to drink", "with a stagger",
              "lurching unsteadily", "reeling", "like an intoxicated person"),
    "gorilla": ("like a gorilla", "like a monkey", "like an ape", "like a chimp", "like a chimpanzee",
                "like a primate", "like an orangutan", "in an apelike way", "with long hanging arms",
                "lumbering like a gorilla",
                "hunched over with the arms hanging low", "like a big ape", "gorilla style", "monkey style"),
    "proud": ("proudly", "like a marching soldier", "in a marching style", "with high knees", "confidently",
              "like a soldier", "triumphantly", "with the chest out", "with the head held high", "with pride",
              "in a proud way", "like a parading soldier", "with big arm swings",
              "boldly", "majestically", "with swagger", "strutting", "with a puffed chest"),
}
# a program without a style may say so
NEUTRAL_PHRASES = ("normally", "naturally", "in a normal way", "in a regular manner", "in an ordinary way",
                   "like a normal person", "without any particular style")
# verbs: (third person, gerund)
VERBS = {
    "walk": (("walks", "walking"), ("strolls", "strolling"), ("paces", "pacing"), ("ambles", "ambling"),
             ("treads", "treading"), ("strides", "striding"), ("steps", "stepping"), ("wanders", "wandering"),
             ("moves", "moving"), ("goes", "going"), ("heads", "heading"), ("proceeds", "proceeding"),
             ("walks along", "walking along"), ("takes a walk", "taking a walk"), ("travels on foot", "traveling on foot")),
    "run": (("runs", "running"), ("sprints", "sprinting"), ("dashes", "dashing"), ("races", "racing"),
            ("rushes", "rushing"), ("hurries", "hurrying"), ("bolts", "bolting"), ("runs along", "running along"),
            ("goes for a run", "going for a run"), ("breaks into a run", "breaking into a run")),
    "jog": (("jogs", "jogging"), ("trots", "trotting"), ("runs lightly", "running lightly"), ("lopes", "loping"),
            ("jogs along", "jogging along"), ("goes for a jog", "going for a jog"), ("does a light jog", "doing a light jog"),
            ("runs at a jogging pace", "running at a jogging pace")),
    "walk_backward": (("walks", "walking"), ("steps", "stepping"), ("moves", "moving"), ("backs up", "backing up"),
                      ("backs away", "backing away"), ("retreats", "retreating"), ("walks in reverse", "walking in reverse"),
                      ("steps back", "stepping back"), ("moves back", "moving back"), ("reverses", "reversing")),
    "side_step": (("side steps", "side stepping"), ("steps sideways", "stepping sideways"),
                  ("shuffles sideways", "shuffling sideways"), ("sidesteps", "sidestepping"),
                  ("moves sideways", "moving sideways"), ("slides sideways", "sliding sideways"),
                  ("walks sideways", "walking sideways"), ("strafes", "strafing"), ("crab walks", "crab walking"),
                  ("moves laterally", "moving laterally"), ("shuffles", "shuffling")),
    "turn": (("turns", "turning"), ("rotates", "rotating"), ("spins", "spinning"), ("pivots", "pivoting"),
             ("swivels", "swiveling"), ("turns the body", "turning the body"), ("rotates the body", "rotating the body"),
             ("changes direction", "changing direction")),
    "jump": (("jumps", "jumping"), ("leaps", "leaping"), ("bounces", "bouncing"), ("springs up", "springing up"),
             ("jumps up", "jumping up"), ("leaps up", "leaping up"), ("does a jump", "doing a jump"),
             ("does a vertical jump", "doing a vertical jump")),
    "jump_forward": (("jumps forward", "jumping forward"), ("leaps forward", "leaping forward"),
                     ("jumps ahead", "jumping ahead"), ("bounds forward", "bounding forward"),
                     ("does a long jump", "doing a long jump"), ("does a broad jump", "doing a broad jump"),
                     ("springs forward", "springing forward"), ("long jumps", "long jumping")),
    "hop": (("hops", "hopping"), ("jumps", "jumping"), ("bounces", "bouncing"), ("hops up and down", "hopping up and down"),
            ("springs", "springing"), ("hops up", "hopping up")),
    "jumping_jacks": (("does jumping jacks", "doing jumping jacks"), ("performs jumping jacks", "performing jumping jacks"),
                      ("does star jumps", "doing star jumps"), ("does some jumping jacks", "doing some jumping jacks"),
                      ("exercises with jumping jacks", "exercising with jumping jacks"),
                      ("works out with jumping jacks", "working out with jumping jacks"),
                      ("does side straddle hops", "doing side straddle hops")),
    "squat": (("squats", "squatting"), ("squats down", "squatting down"), ("does a squat", "doing a squat"),
              ("bends the knees", "bending the knees"), ("does a knee bend", "doing a knee bend"),
              ("lowers into a squat", "lowering into a squat"), ("drops into a squat", "dropping into a squat"),
              ("squats and stands back up", "squatting and standing back up"), ("crouches down", "crouching down"),
              ("squats down and gets back up", "squatting down and getting back up")),
    "kick": (("kicks", "kicking"), ("kicks out", "kicking out"), ("does a kick", "doing a kick"),
             ("kicks the air", "kicking the air"), ("throws a kick", "throwing a kick"),
             ("delivers a kick", "delivering a kick"), ("kicks forward", "kicking forward"),
             ("does a front kick", "doing a front kick")),
    "punch": (("punches", "punching"), ("throws a punch", "throwing a punch"), ("punches forward", "punching forward"),
              ("jabs", "jabbing"), ("strikes", "striking"), ("boxes", "boxing"), ("throws a jab", "throwing a jab"),
              ("punches the air", "punching the air"), ("jabs forward", "jabbing forward"), ("hits the air", "hitting the air")),
    "wave": (("waves", "waving"), ("waves hello", "waving hello"), ("waves goodbye", "waving goodbye"),
             ("waves hi", "waving hi"), ("waves bye", "waving bye"), ("gives a wave", "giving a wave"),
             ("waves to someone", "waving to someone"), ("greets someone with a wave", "greeting someone with a wave"),
             ("waves a greeting", "waving a greeting")),
    "clap": (("claps", "clapping"), ("claps the hands", "clapping the hands"), ("claps hands", "clapping hands"),
             ("applauds", "applauding"), ("claps the hands together", "clapping the hands together"),
             ("brings the hands together", "bringing the hands together"),
             ("claps in front of the body", "clapping in front of the body"),
             ("claps at chest height", "clapping at chest height")),
    # the arms (or hands) follow the verb
    "raise_arms": (("raises", "raising"), ("lifts", "lifting"), ("puts up", "putting up"), ("brings up", "bringing up"),
                   ("reaches up with", "reaching up with"), ("stretches up", "stretching up"),
                   ("extends upward", "extending upward")),
    "bow": (("bows", "bowing"), ("takes a bow", "taking a bow"), ("bends forward to bow", "bending forward to bow"),
            ("bows down", "bowing down"), ("bends over", "bending over"), ("bends forward", "bending forward"),
            ("bows politely", "bowing politely"), ("bows respectfully", "bowing respectfully"),
            ("gives a bow", "giving a bow"), ("bends at the waist", "bending at the waist"),
            ("bows from the waist", "bowing from the waist"), ("leans forward in a bow", "leaning forward in a bow")),
    "dance": (("dances", "dancing"), ("dances from side to side", "dancing from side to side"),
              ("does a little dance", "doing a little dance"), ("grooves", "grooving"), ("boogies", "boogieing"),
              ("moves to the music", "moving to the music"), ("dances to the beat", "dancing to the beat"),
              ("busts a move", "busting a move"), ("dances in place", "dancing in place"),
              ("steps side to side to the beat", "stepping side to side to the beat"),
              ("bops to the music", "bopping to the music"), ("does a step touch dance", "doing a step touch dance"),
              ("grooves to the rhythm", "grooving to the rhythm")),
    "stand": (("stands still", "standing still"), ("stands in place", "standing in place"), ("stays still", "staying still"),
              ("stands there", "standing there"), ("waits", "waiting"), ("remains still", "remaining still"),
              ("stands idle", "standing idle"), ("does nothing", "doing nothing"), ("stays in place", "staying in place"),
              ("stands motionless", "standing motionless"), ("waits in place", "waiting in place"),
              ("idles", "idling"), ("remains standing", "remaining standing"), ("holds still", "holding still"),
              ("pauses", "pausing"), ("rests", "resting"), ("stands around", "standing around")),
}
# phrases that already say "backward" (no direction word after them)
_SAYS_BACKWARD = ("back", "retreat", "reverse")
DIRECTION_WORDS = {
    "forward": ("forward", "ahead", "straight ahead", "forwards", "onward", "to the front", "in a straight line",
                "straight forward", "along a straight path"),
    "backward": ("backward", "backwards", "in reverse", "rearward", "back"),
    "left": ("to the left", "toward the left", "and turns left", "curving left", "leftward", "veering left",
             "bearing left", "along a curve to the left", "in a curve to the left", "off to the left"),
    "right": ("to the right", "toward the right", "and turns right", "curving right", "rightward", "veering right",
              "bearing right", "along a curve to the right", "in a curve to the right", "off to the right"),
    "circle_left": ("in a circle", "in a circle to the left", "around in a circle", "in a counterclockwise circle",
                    "in a loop", "in a circular path", "on a circular path", "around in a loop",
                    "in an anticlockwise circle", "in a circle going left"),
    "circle_right": ("in a circle", "in a circle to the right", "around in a circle", "in a clockwise circle",
                     "in a loop", "in a circular path", "on a circular path", "around in a loop",
                     "in a circle going right"),
}
SIDE_STEP_WORDS = ("to the {d}", "toward the {d}", "{d}ward", "over to the {d}", "in the {d} direction")
TURN_WORDS = {"around": ("around", "all the way around", "to face the other way", "to face the opposite direction",
                         "to face backward", "by a hundred and eighty degrees", "halfway around", "through a half turn"),
              "left": ("to the left", "left", "toward the left", "ninety degrees to the left",
                       "a quarter turn to the left", "by ninety degrees to the left", "counterclockwise",
                       "to face left"),
              "right": ("to the right", "right", "toward the right", "ninety degrees to the right",
                        "a quarter turn to the right", "by ninety degrees to the right", "clockwise",
                        "to face right")}
IN_PLACE = ("in place", "on the spot", "without moving from the spot")
JUMP_PLACE = ("in place", "up and down", "on the spot", "straight up", "vertically", "into the air")
HOP_SIDE = ("on the {side} leg", "on the {side} foot", "on one leg", "on just the {side} leg", "on a single leg",
            "balancing on the {side} leg")
HOP_UNSAID = ("on one leg", "on one foot", "on a single leg")
INTENSITY_WORDS = {
    "jump": {"high": ("high", "very high", "really high", "as high as possible", "high into the air", "powerfully"),
             "a little": ("a little", "slightly", "a tiny bit", "just a little", "lightly", "low")},
    "kick": {"high": ("high", "very high", "up high", "powerfully", "hard"),
             "a little": ("low", "a little", "softly", "lightly")},
    "squat": {"high": ("deeply", "all the way down", "very low", "as low as possible"),
              "a little": ("a little", "slightly", "only halfway", "partway", "shallowly")},
    "bow": {"high": ("deeply", "very deeply", "low"), "a little": ("slightly", "a little", "just a little")},
    "wave": {"high": ("energetically", "vigorously", "wildly", "with big motions", "widely"),
             "a little": ("a little", "gently", "softly", "slightly", "with small motions")},
}
LIMB = {"hand": ("hand", "arm"), "leg": ("leg", "foot"), "fist": ("hand", "arm", "fist")}
PLURAL = {"hand": "hands", "arm": "arms", "leg": "legs", "foot": "feet", "fist": "fists"}
RAISE_OBJECTS = {"unsaid": ("an arm", "a hand", "the arms", "the hands"),
                 "both": ("both arms", "both hands", "the arms", "the hands", "both of the arms"),
                 "one": ("the {side} arm", "the {side} hand")}
RAISE_WHERE = ("above the head", "over the head", "overhead", "into the air", "up high", "toward the sky",
               "toward the ceiling")
RAISE_LOWER = {"plural": ("and lowers them again", "and then lowers them", "and brings them back down",
                          "and puts them down again"),
               "single": ("and lowers it again", "and then lowers it", "and brings it back down",
                          "and puts it down again")}
RAISE_LOWER_ING = {"plural": ("and lowering them again", "and bringing them back down"),
                   "single": ("and lowering it again", "and bringing it back down")}
BOW_BACK = (("and straightens up again", "and straightening up again"), ("and comes back up", "and coming back up"))
SEQ_JOIN = (", then ", " and then ", ", after that ", ", and afterwards ", " before ", " then ", ", next ",
            ", afterwards ", " and later ", ", and after that ", ", followed by ", ", subsequently ",
            " and right after that ", " and ", ", and finally ")
ING_JOIN = (", then ", " and then ", " before ", " then ", ", followed by ", " and ", ", and finally ")
# joins after which the next phrase is a gerund
GERUND_JOINS = (" before ", ", followed by ")
# overlays: (join, form): form None = the main phrase's form
OVERLAY_JOINS = ((" while ", 1), (" whilst ", 1), (" while also ", 1), (", all the while ", 1),
                 (" and at the same time ", None), (" and simultaneously ", None))
# templates: {s} subject, {vp} verb phrase (3rd person), {ing} gerund phrase
TEMPLATES = {
    "simple": "{s} {vp}",
    "progressive": "{s} is {ing}",
    "sees": "we see {s} {ing}",
    "shows": "this motion shows {s} {ing}",
    "first": "{s} first {vp}",
    "starts": "{s} starts {ing}",
    "begins": "{s} begins {ing}",
    "footage": "a video of {s} {ing}",
    "animation": "an animation of {s} {ing}",
    "bare": "{vp}",
    "bare_ing": "{ing}",
}
# the plain "{s} {vp}" is drawn more often than the others
_TEMPLATE_DRAW = ("simple", "simple", "simple", "progressive", "progressive", "sees", "shows", "first", "starts",
                  "begins", "footage", "animation", "bare", "bare_ing")
HELD_OUT_TEMPLATES = {
    "video": "in this clip {s} can be seen {ing}",
    "here": "here {s} keeps {ing}",
}
_FILLER = ("and", "with", "the", "both", "while", "then", "after", "that", "afterwards", "before", "arms",
           "hands", "his", "her", "its", "in", "place", "one", "on", "to", "is", "a", "times")
_OBJECT_CASE = {"he": "him", "she": "her"}
_SHORT_SUBJECTS = tuple(s for s in SUBJECTS if len(s.split()) <= 2)
_SEGMENT_GESTURES = ("wave", "clap", "punch", "raise_arms")


def _pick(rng: np.random.Generator, options):
    return options[int(rng.integers(len(options)))]


def _side_phrase(seg: Segment, rng, limb: str, *, bare: bool) -> str:
    """"with the left hand"; ``bare`` also allows "the left hand" right after a one-word verb."""
    side = seg.side
    word = _pick(rng, LIMB[limb])
    if side == "both":
        return _pick(rng, (f"with both {PLURAL[word]}", f"using both {PLURAL[word]}"))
    if side in ("left", "right"):
        options = [f"with the {side} {word}", f"using the {side} {word}"]
        if bare:
            options.append(f"the {side} {word}")
        return _pick(rng, tuple(options))
    return ""


def _count_phrase(seg: Segment, rng) -> str:
    c = max(1, min(seg.count, 5))
    return _pick(rng, COUNT_WORDS[c])


def _counted_noun(seg: Segment, form: int, rng) -> str:
    """"does three squats", "throws a single punch"."""
    one, many, verbs = COUNT_NOUNS[seg.action]
    c = max(1, min(seg.count, 5))
    verb = _pick(rng, verbs)[form]
    return f"{verb} {_pick(rng, SINGLE)} {one}" if c == 1 else f"{verb} {COUNT_NUMBERS[c]} {many}"


def action_phrase(seg: Segment, form: int, rng: np.random.Generator, *, with_count: bool = True,
                  with_side: bool = True, short: bool = False, plain: float = 0.0) -> str:
    """Verb phrase for a segment; form 0 = third person ("walks"), 1 = gerund ("walking"). ``with_count`` and
    ``with_side`` False leave the count and the side unsaid; ``short`` prefers a one-word verb; ``plain`` is the
    chance of the action's plain verb (the first of its table: "walks", "punches") instead of a synonym."""
    a = seg.action
    counted = with_count and a in COUNT_NOUNS and rng.random() < 0.2
    verbs = VERBS[a]
    if plain > 0 and not counted and rng.random() < plain:
        verbs = verbs[:1]
    elif short:
        verbs = tuple(v for v in verbs if " " not in v[0]) or verbs[:1]
    verb = _counted_noun(seg, form, rng) if counted else _pick(rng, verbs)[form]
    parts = [verb]
    extra = []
    if a in ("walk", "run", "jog") and seg.direction in DIRECTION_WORDS:
        options = DIRECTION_WORDS[seg.direction]
        if verb.endswith(" along"):  # not "jogs along along a curve"
            options = tuple(d for d in options if not d.startswith("along")) or options
        extra.append(_pick(rng, options))
    elif a == "walk_backward":
        if not any(w in verb for w in _SAYS_BACKWARD):
            extra.append(_pick(rng, DIRECTION_WORDS["backward"]))
    elif a == "side_step":
        d = "left" if seg.direction != "right" else "right"
        extra.append(_pick(rng, SIDE_STEP_WORDS).format(d=d))
    elif a == "turn":
        key = "around" if abs(seg.turn) > 2.5 else ("left" if seg.turn > 0 else "right")
        extra.append(_pick(rng, TURN_WORDS[key]))
        if rng.random() < 0.5:
            extra.append(_pick(rng, IN_PLACE))
    elif a == "jump" and rng.random() < 0.3:
        extra.append(_pick(rng, tuple(p for p in JUMP_PLACE if not (" up" in verb and "up" in p.split()))))
    elif a == "hop":
        if with_side and seg.side in ("left", "right"):
            extra.append(_pick(rng, HOP_SIDE).format(side=seg.side))
        elif rng.random() < 0.5:  # a side left unsaid
            extra.append(_pick(rng, HOP_UNSAID))
    elif a == "kick":  # never "kicks the left leg" (that reads as kicking one's own leg)
        parts.append(_side_phrase(seg, rng, "leg", bare=False) if with_side else "")
    elif a == "punch":  # never "punches the left hand"
        parts.append(_side_phrase(seg, rng, "fist", bare=False) if with_side else "")
    elif a == "wave":
        parts.append(_side_phrase(seg, rng, "hand", bare=" " not in verb) if with_side else "")
    elif a == "raise_arms":
        side = seg.side if seg.side != "none" else "both"
        if not with_side:
            obj = _pick(rng, RAISE_OBJECTS["unsaid"])
        elif side == "both":
            obj = _pick(rng, RAISE_OBJECTS["both"])
        else:
            obj = _pick(rng, RAISE_OBJECTS["one"]).format(side=side)
        parts.append(obj)
        if verb.startswith("lift") or verb.startswith("rais"):
            if rng.random() < 0.4:
                parts.append("up")
        if rng.random() < 0.4:
            parts.append(_pick(rng, tuple(w for w in RAISE_WHERE if not ("up" in verb.split() and w == "up high"))))
        if rng.random() < 0.25:  # the primitive lowers the arms after each raise
            number = "single" if obj.startswith(("an ", "a ")) or not obj.endswith("s") else "plural"
            parts.append(_pick(rng, (RAISE_LOWER if form == 0 else RAISE_LOWER_ING)[number]))
    elif a == "bow" and not counted and rng.random() < 0.2:  # the primitive comes back up after each bow
        parts.append(_pick(rng, BOW_BACK)[form])
    if with_count and not counted and a in ("jump", "jump_forward", "hop", "squat", "kick", "punch", "wave", "clap",
                                            "bow", "raise_arms", "jumping_jacks"):
        if a == "jumping_jacks":
            c = max(1, min(seg.count, 5))
            if rng.random() < 0.5 and re.search(r"jumping jacks|star jumps", verb):
                if c == 1:  # "does a single jumping jack"
                    parts = [re.sub(r"(some )?(jumping jack|star jump)s", rf"{_pick(rng, SINGLE)} \2", verb)]
                else:
                    parts = [re.sub(r"(some )?(jumping jacks|star jumps)", rf"{COUNT_NUMBERS[c]} \2", verb)]
            else:
                extra.append(_count_phrase(seg, rng))
        else:
            extra.append(_count_phrase(seg, rng))
    key = {"jump_forward": "jump", "hop": "jump"}.get(a, a)
    if seg.intensity_word in ("high", "a little") and key in INTENSITY_WORDS:
        extra.append(_pick(rng, INTENSITY_WORDS[key][seg.intensity_word]))
    if seg.speed_word in SPEED_WORDS and a != "stand":
        sp = _pick(rng, SPEED_WORDS[seg.speed_word])
        if form == 0 and " " not in sp and sp.endswith("ly") and rng.random() < 0.35:
            parts.insert(0, sp)  # "slowly walks"
        else:
            extra.append(sp)
    extra = [e for e in extra if e]
    order = rng.permutation(len(extra)) if rng.random() < 0.3 else np.arange(len(extra))
    return " ".join(parts + [extra[i] for i in order])


def _vp(program: Program, rng, style: bool) -> str:
    """Third-person phrase; "before" / "followed by" joins switch the following phrase to a gerund."""
    return _joined(program, rng, style, joins=SEQ_JOIN, gerund_after_before=True)


def _ing(program: Program, rng, style: bool) -> str:
    """Gerund phrase ("walking, then jumping")."""
    return _joined(program, rng, style, joins=ING_JOIN, gerund_after_before=False)


def _join_for(program: Program, i: int, rng, joins) -> str:
    """A sequence join before segment ``i``: "and finally" only before the last one, a plain "and" never before an
    arm gesture (that would read as simultaneous: "walks and waves")."""
    options = [j for j in joins
               if not (j == ", and finally " and i != len(program.segments) - 1)
               and not (j == " and " and program.segments[i].action in _SEGMENT_GESTURES)]
    return _pick(rng, options)


def _joined(program: Program, rng, style: bool, *, joins, gerund_after_before: bool) -> str:
    """The segments' phrases joined in order, an overlay as "while ...", the style phrase on one of them."""
    parts = []
    sty_at = int(rng.integers(len(program.segments))) if program.style != "none" and style else -1
    neutral_at = -1
    if program.style == "none" and style and rng.random() < 0.12:
        neutral_at = int(rng.integers(len(program.segments)))
    for i, seg in enumerate(program.segments):
        join = "" if i == 0 else _join_for(program, i, rng, joins)
        form = 1 if not gerund_after_before or join in GERUND_JOINS else 0
        p = action_phrase(seg, form, rng)
        if seg.overlay is not None:
            ojoin, oform = _pick(rng, OVERLAY_JOINS)
            p += ojoin + action_phrase(seg.overlay, form if oform is None else oform, rng)
        if i == sty_at:
            p += " " + _pick(rng, STYLE_PHRASES[program.style])
        elif i == neutral_at:
            p += " " + _pick(rng, NEUTRAL_PHRASES)
        parts.append(join + p)
    return "".join(parts)


def captions(program: Program, rng: np.random.Generator, *, n: int = 4, held_out: bool = False) -> list[str]:
    """``n`` (>= 3) distinct paraphrases. ``held_out`` draws only from the held-out templates."""
    pool = HELD_OUT_TEMPLATES if held_out else TEMPLATES
    names = list(pool) if held_out else list(_TEMPLATE_DRAW)
    out: list[str] = []
    tries = 0
    while len(out) < n and tries < 40:
        tries += 1
        name = names[(len(out) + int(rng.integers(len(names)))) % len(names)] if tries > 1 else _pick(rng, names)
        tpl = pool[name]
        subj = _pick(rng, SUBJECTS)
        if re.search(r"(see|shows|of) \{s\}", tpl):  # the subject is an object there: "we see him walking"
            subj = _OBJECT_CASE.get(subj, subj)
        text = tpl.format(s=subj, vp=_vp(program, rng, True) if "{vp}" in tpl else "",
                          ing=_ing(program, rng, True) if "{ing}" in tpl else "")
        # a style phrase may also open the sentence ("happily, a person walks")
        text = re.sub(r"\s+", " ", text).strip()
        if text not in out:
            out.append(text)
    return out


# a styled person named as people type it ("a zombie walks", "an old man walks"): the style as the subject
STYLE_SUBJECTS = {"zombie": ("a zombie",), "old": ("an old man", "an old woman", "an elderly person"),
                  "robot": ("a robot",), "drunk": ("a drunk man", "a drunk person"), "happy": ("a happy person",),
                  "sad": ("a sad person", "a sad man"), "proud": ("a proud man", "a proud woman")}


def underspecified_captions(program: Program, rng: np.random.Generator, *, n: int = 2,
                            plain: float = 0.0, styled: float = 0.0, keep_intensity: bool = False) -> list[str]:
    """Captions that leave attributes out, the way people type ("a person waves" for a left-hand wave, twice).

    Side, count, speed, intensity and style are each dropped at random, keeping the meaning: an unstated side
    covers either hand, an unstated count any count. About a third are bare subject-and-verb captions of two to
    four words ("someone kicks"). ``plain``: the chance that a segment's verb is the action's plain one ("walks",
    not "treads"), as people mostly type it. ``styled``: the chance that a styled motion's caption keeps its style,
    bare ones included ("a person walks like a robot", "a zombie walks": the style as a phrase on one segment, or as
    the subject where :data:`STYLE_SUBJECTS` has one); otherwise the style is dropped. ``keep_intensity``: a caption that
    is not bare keeps its intensity word ("waves energetically"), so a big wave is not mostly captioned plainly. Only words of the phrase
    tables are used, so :func:`vocabulary` is unchanged.
    """
    from dataclasses import replace as _replace

    out: list[str] = []
    for _ in range(6 * n):
        if len(out) >= n:
            break
        bare = rng.random() < 0.35
        segments = []
        for seg in program.segments:
            fields = {}
            say_side = not (bare or rng.random() < 0.6)
            if bare or rng.random() < 0.6:
                fields["speed_word"] = "normal"
            if bare or (rng.random() < 0.6 and not keep_intensity):  # (the same draws whether kept or not)
                fields["intensity_word"] = "normal"
            if bare and seg.action in ("walk", "run", "jog") and rng.random() < 0.7:
                fields["direction"] = "none"
            keep_count = not bare and rng.random() < 0.5
            overlay = None if bare else seg.overlay
            segments.append((_replace(seg, overlay=overlay, **fields), keep_count, say_side))
        parts = []
        for i, (seg, keep_count, say_side) in enumerate(segments):
            join = "" if i == 0 else _pick(rng, (", then ", " and then ", ", after that "))
            phrase = action_phrase(seg, 0, rng, with_count=keep_count, with_side=say_side, short=bare, plain=plain)
            if seg.overlay is not None:
                phrase += " while " + action_phrase(seg.overlay, 1, rng, with_count=False, with_side=False)
            parts.append(join + phrase)
        subject = _pick(rng, _SHORT_SUBJECTS if bare else SUBJECTS)
        # (drawn after the rest, so that styled=0 draws exactly what it drew before the option existed)
        if program.style != "none" and styled and rng.random() < styled:
            if program.style in STYLE_SUBJECTS and rng.random() < 0.5:
                subject = _pick(rng, STYLE_SUBJECTS[program.style])
            else:
                at = int(rng.integers(len(parts)))
                parts[at] += " " + _pick(rng, STYLE_PHRASES[program.style])
        text = re.sub(r"\s+", " ", f"{subject} {''.join(parts)}").strip()
        if text not in out:
            out.append(text)
    return out


def words(text: str) -> list[str]:
    """Lowercase words with punctuation stripped (the tokeniser's view)."""
    return re.findall(r"[a-z]+", text.lower())


def _strings(table) -> list[str]:
    """All strings of a (nested) phrase table: dict values, tuples, lists."""
    if isinstance(table, str):
        return [table]
    if isinstance(table, dict):
        table = list(table.values())
    out: list[str] = []
    for item in table:
        out.extend(_strings(item))
    return out


def vocabulary() -> tuple[str, ...]:
    """Every word any caption of any split can contain (sorted)."""
    found: set[str] = set()
    tables = (SUBJECTS, COUNT_WORDS, COUNT_NUMBERS, COUNT_NOUNS, SINGLE, SPEED_WORDS, STYLE_PHRASES, NEUTRAL_PHRASES,
              VERBS, DIRECTION_WORDS, TURN_WORDS, IN_PLACE, JUMP_PLACE, HOP_UNSAID, INTENSITY_WORDS, LIMB,
              RAISE_WHERE, RAISE_LOWER, RAISE_LOWER_ING, BOW_BACK, SEQ_JOIN, ING_JOIN,
              tuple(j for j, _ in OVERLAY_JOINS), _FILLER, TEMPLATES, HELD_OUT_TEMPLATES)
    for t in _strings((tables, _OBJECT_CASE)):
        found.update(words(re.sub(r"\{\w+\}", " ", t)))
    # the slots {side} / {d} ({d}ward: leftward, rightward) and the side phrases' words
    for t in _strings((SIDE_STEP_WORDS, HOP_SIDE, RAISE_OBJECTS)):
        for side in ("left", "right"):
            found.update(words(t.format(d=side, side=side)))
    for t in ("using", "up", "jumping jacks", "star jumps", "jumping jack", "star jump", "left", "right", "legs", "feet", "fists"):
        found.update(words(t))
    found.update(words(" ".join(PLURAL.values())))
    return tuple(sorted(found))


VOCABULARY_FILE = Path(__file__).with_name("vocabulary.txt")


def write_vocabulary(path: Path = VOCABULARY_FILE) -> Path:
    path.write_text("\n".join(vocabulary()) + "\n")
    return path


# ------------------------------------------------------------------------ HumanML3D tokens
_POS = {
    "a": "DET", "the": "DET", "both": "DET", "this": "DET", "his": "DET", "her": "DET", "its": "DET",
    "someone": "PRON", "we": "PRON", "he": "PRON", "she": "PRON", "and": "CCONJ", "then": "ADV",
    "while": "SCONJ", "before": "ADP", "after": "ADP", "that": "PRON", "afterwards": "ADV", "to": "ADP",
    "in": "ADP", "on": "ADP", "with": "ADP", "like": "ADP", "as": "ADP", "at": "ADP", "toward": "ADP",
    "around": "ADV", "from": "ADP", "up": "ADP", "down": "ADV", "out": "ADP", "is": "AUX", "can": "AUX",
    "be": "AUX", "seen": "VERB", "keeps": "VERB", "once": "ADV", "twice": "ADV", "thrice": "ADV",
    "one": "NUM", "two": "NUM", "three": "NUM", "four": "NUM", "five": "NUM", "left": "ADJ", "right": "ADJ",
    "forward": "ADV", "forwards": "ADV", "ahead": "ADV", "straight": "ADV", "backward": "ADV",
    "backwards": "ADV", "sideways": "ADV", "high": "ADV", "very": "ADV", "little": "ADJ", "tiny": "ADJ",
    "slow": "ADJ", "fast": "ADV", "all": "DET", "way": "NOUN", "here": "ADV", "first": "ADV", "side": "NOUN",
    "other": "ADJ", "low": "ADV", "deeply": "ADV", "elderly": "ADJ", "old": "ADJ", "sad": "ADJ", "happy": "ADJ",
    "drunk": "ADJ", "clockwise": "ADJ", "counterclockwise": "ADJ", "marching": "VERB", "spot": "NOUN",
    "hello": "INTJ", "using": "VERB", "raised": "VERB", "holding": "VERB", "crouching": "VERB",
    "flapping": "VERB", "curving": "VERB", "shows": "VERB", "see": "VERB", "air": "NOUN", "place": "NOUN",
}
_LEMMA = {"feet": "foot", "jacks": "jack", "jumps": "jump", "knees": "knee", "arms": "arm", "hands": "hand",
          "legs": "leg", "times": "time", "keeps": "keep", "shows": "show", "seen": "see", "is": "be",
          "degrees": "degree", "elbows": "elbow", "fists": "fist", "motions": "motion", "movements": "movement",
          "shoulders": "shoulder", "swings": "swing", "wings": "wing"}
_POS.update({w: "ADP" for w in ("above", "along", "by", "for", "into", "of", "off", "over", "through", "without")})
_POS.update({w: "ADV" for w in ("again", "also", "away", "back", "just", "later", "next", "together", "too", "there",
                                "halfway", "onward", "leftward", "rightward", "rearward", "upward", "overhead",
                                "partway", "finally", "only", "really", "wobbly")})
_POS.update({w: "DET" for w in ("an", "any", "my", "some")})
_POS.update({w: "PRON" for w in ("him", "it", "them", "who", "somebody", "nothing")})
_POS.update({w: "SCONJ" for w in ("if", "whilst")})
_POS.update({w: "INTJ" for w in ("hi", "bye", "goodbye")})
_POS.update({w: "NUM" for w in ("hundred", "eighty", "ninety")})
_POS.update({w: "ADJ" for w in (
    "several", "few", "single", "still", "big", "small", "quick", "rapid", "easy", "relaxed", "normal", "regular",
    "ordinary", "particular", "good", "heavy", "light", "long", "broad", "vertical", "circular", "mechanical",
    "robotic", "stiff", "jerky", "sneaky", "cheerful", "upbeat", "drunken", "intoxicated", "depressed", "young",
    "aged", "senior", "opposite", "same", "possible", "proud", "motionless", "outstretched", "hunched", "stooped",
    "slumped", "puffed", "bent", "idle", "undead", "apelike", "anticlockwise", "hard", "much", "front")})
# verbs outside the VERBS table (participles, template verbs): word -> lemma
_OTHER_VERBS = {
    "begins": "begin", "starts": "start", "followed": "follow", "gets": "get", "getting": "get", "comes": "come",
    "coming": "come", "makes": "make", "making": "make", "had": "have", "swaying": "sway", "wobbling": "wobble",
    "staggering": "stagger", "reeling": "reel", "lurching": "lurch", "lumbering": "lumber", "prowling": "prowl",
    "strutting": "strut", "shambling": "shamble", "surrendering": "surrender", "straightening": "straighten",
    "straightens": "straighten", "balancing": "balance", "hanging": "hang", "veering": "veer", "bearing": "bear",
    "drooping": "droop", "parading": "parade", "flapping": "flap", "curving": "curve", "crouching": "crouch",
    "holding": "hold", "raised": "raise", "held": "hold", "hung": "hang", "stretched": "stretch",
    "marching": "march", "using": "use", "seen": "see", "keeps": "keep", "shows": "show", "see": "see",
    "stands": "stand", "standing": "stand", "drink": "drink",
}
_THIRD_LEMMA = {"does": "do", "goes": "go", "boogies": "boogie", "hurries": "hurry", "boxes": "box"}


def _third_lemma(w3: str) -> str:
    if w3 in _THIRD_LEMMA:
        return _THIRD_LEMMA[w3]
    if w3.endswith(("ches", "shes", "sses", "xes")):
        return w3[:-2]
    if w3.endswith("ies"):
        return w3[:-3] + "y"
    return w3[:-1]


def _verb_lemmas() -> dict[str, str]:
    """The verb of each (third person, gerund) pair: the first word where the two forms differ ("crab walks")."""
    out: dict[str, str] = {}
    for forms in VERBS.values():
        for third, gerund in forms:
            for w3, wg in zip(third.split(), gerund.split()):
                if w3 != wg:
                    lemma = _third_lemma(w3)
                    out[w3] = lemma
                    out[wg] = lemma
                    break
    for verbs in (v for _, _, vs in COUNT_NOUNS.values() for v in vs):
        out[verbs[0]] = _third_lemma(verbs[0])
        out[verbs[1]] = out[verbs[0]]
    # the second verb of "squats and stands back up", "squats down and gets back up"
    for third, gerund in (p for forms in VERBS.values() for p in forms):
        w3s, wgs = third.split(), gerund.split()
        if "and" in w3s and w3s[w3s.index("and") + 1] != wgs[w3s.index("and") + 1]:
            k = w3s.index("and") + 1
            out.setdefault(w3s[k], _OTHER_VERBS.get(w3s[k], _third_lemma(w3s[k])))
            out.setdefault(wgs[k], out[w3s[k]])
    for w, lemma in _OTHER_VERBS.items():
        out.setdefault(w, lemma)
    return out


_VERB_LEMMA = _verb_lemmas()


def _lemma_pos(word: str) -> tuple[str, str]:
    if word in _VERB_LEMMA:
        return _VERB_LEMMA[word], "VERB"
    if word in _POS:
        pos = _POS[word]
    elif word.endswith("ly"):
        pos = "ADV"
    else:
        pos = "NOUN"
    return _LEMMA.get(word, word), pos


def tokens(text: str) -> str:
    """HumanML3D token string: ``word/POS`` (lemmatised) separated by spaces."""
    return " ".join("/".join(_lemma_pos(w)) for w in words(text))
