from gearmesh_dev.cli import main

raise SystemExit(main())
