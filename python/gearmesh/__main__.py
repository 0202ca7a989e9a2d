from gearmesh.cli import main

raise SystemExit(main())
