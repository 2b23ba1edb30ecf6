"""Result folders and the files in them: one invocation's folder appears whole or not at all
(``folder.OutputFolder``), its manifest lists every file with size and sha256
(``folder.inventory``/``folder.verify``), a running train or study owns its folder
(``folder.FolderLock``), and the hidden temporaries of killed processes are removed on the next
start (``folder.clean_stale_temporaries``)."""
