import sys

from farm_server.cli import main

sys.exit(main())
