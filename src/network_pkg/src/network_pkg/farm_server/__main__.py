import sys

from network_pkg.farm_server.cli import main

sys.exit(main())
