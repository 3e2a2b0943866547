from surrogates.cli import main

raise SystemExit(main())
