"""One-sentence natural-language descriptions of the 50 Meta-World tasks (CARE's task metadata).

Written for mtbench; they describe what the robot arm has to achieve in each task and are embedded by a sentence
encoder (see :mod:`mtbench.modules.task_embeddings`) to give CARE its task context.
"""

from __future__ import annotations

import re

METAWORLD_TASK_DESCRIPTIONS: dict[str, str] = {
    "assembly": "Pick up a round nut by its handle and fit it down over a vertical peg.",
    "basketball": "Grasp a basketball and drop it through the hoop.",
    "bin_picking": "Pick a small cube out of one bin and place it into the other bin.",
    "box_close": "Pick up the box lid and put it on top of the box to close it.",
    "button_press_topdown": "Press a button downward from above.",
    "button_press_topdown_wall": "Press a button downward from above while a short wall stands in front of it.",
    "button_press": "Push a button horizontally into the wall-mounted panel.",
    "button_press_wall": "Push a horizontal button on a panel that is partly hidden behind a short wall.",
    "coffee_button": "Push the button on the front of the coffee machine.",
    "coffee_pull": "Pull a coffee mug away from underneath the coffee machine to a goal position.",
    "coffee_push": "Push a coffee mug underneath the spout of the coffee machine.",
    "dial_turn": "Turn a dial on the table to the goal angle.",
    "disassemble": "Grasp the nut by its handle and lift it up and off the peg.",
    "door_close": "Push an open door shut by swinging it on its hinges.",
    "door_lock": "Turn the door's lock lever downward to lock the door.",
    "door_unlock": "Turn the door's lock lever upward to unlock the door.",
    "door_open": "Grab the door handle and swing the door open on its hinges.",
    "drawer_close": "Push an open drawer back into its cabinet.",
    "drawer_open": "Grab the drawer handle and pull the drawer open.",
    "faucet_close": "Rotate the faucet handle to turn the tap off.",
    "faucet_open": "Rotate the faucet handle the other way to turn the tap on.",
    "hammer": "Pick up a hammer and hit a nail so it is driven into the wall.",
    "hand_insert": "Insert the gripper together with a small block into a hole in the table.",
    "handle_press_side": "Press a lever handle down from the side.",
    "handle_press": "Press a lever handle down from the front.",
    "handle_pull_side": "Pull a lever handle up from the side.",
    "handle_pull": "Pull a lever handle up from the front.",
    "lever_pull": "Rotate a lever by ninety degrees with the gripper.",
    "peg_insert_side": "Pick up a peg and insert it sideways into a hole in a block.",
    "peg_unplug_side": "Pull a peg sideways out of the hole it is plugged into.",
    "pick_out_of_hole": "Pick a small object up out of a hole in the table and lift it to a goal.",
    "pick_place": "Pick up a puck and place it at a goal position in the air.",
    "pick_place_wall": "Pick up a puck, carry it over a wall and place it at the goal.",
    "plate_slide_back_side": "Slide a plate sideways back out of the goal cabinet.",
    "plate_slide_back": "Slide a plate backward out of the goal cabinet towards the robot.",
    "plate_slide_side": "Slide a plate sideways into a cabinet.",
    "plate_slide": "Slide a plate forward into a cabinet.",
    "push_back": "Push a puck backward towards the robot to a goal position.",
    "push": "Push a puck across the table to a goal position.",
    "push_wall": "Push a puck around a wall to a goal position behind it.",
    "reach": "Move the gripper to reach a goal position in the air.",
    "reach_wall": "Reach a goal position on the other side of a short wall.",
    "shelf_place": "Pick up a block and place it on a shelf.",
    "soccer": "Kick a soccer ball into the goal.",
    "stick_pull": "Grasp a stick and use it to pull a container to the goal.",
    "stick_push": "Grasp a stick and use it to push a container to the goal.",
    "sweep_into_goal": "Sweep a puck across the table into a hole.",
    "sweep": "Sweep a puck off the edge of the table.",
    "window_close": "Slide a window closed horizontally.",
    "window_open": "Slide a window open horizontally.",
}

_VERSION_SUFFIX = re.compile(r"_v\d+$")


def canonical_task_name(name: str) -> str:
    """Normalise a task name: lower case, ``-`` -> ``_``, drop a ``-v2``/``-v3`` suffix (``"pick-place-v3"`` -> ``"pick_place"``)."""
    return _VERSION_SUFFIX.sub("", name.strip().lower().replace("-", "_"))


def task_description(name: str) -> str | None:
    """Description of the Meta-World task ``name`` (any of the accepted spellings), or ``None`` if unknown."""
    return METAWORLD_TASK_DESCRIPTIONS.get(canonical_task_name(name))
