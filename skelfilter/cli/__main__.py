import sys

from skelfilter.cli.commands import main

sys.exit(main())
