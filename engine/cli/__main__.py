"""`python -m engine.cli ...` (and `torchrun ... -m engine.cli ...`): the same as the `moattn` script."""
import sys

from engine.cli import main

sys.exit(main())
