import sys

from rasc.cli import main

sys.exit(main())
