import sys

from skelfilter.cli import main

sys.exit(main())
