"""The attention extension point: context, controllers, attach and the recording store."""
from engine.attention.attach import attach, attached_controller
from engine.attention.context import AttnCtx, BatchRoles, StepInfo, WordIndex
from engine.attention.controller import AttentionController, Controller, ControllerStack, stack
from engine.attention.store import AttentionStore, StoreConfig

__all__ = [
    "AttnCtx", "BatchRoles", "StepInfo", "WordIndex",
    "AttentionController", "Controller", "ControllerStack", "stack",
    "AttentionStore", "StoreConfig", "attach", "attached_controller",
]
