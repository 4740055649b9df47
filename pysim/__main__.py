from pysim.cli import main

raise SystemExit(main())
