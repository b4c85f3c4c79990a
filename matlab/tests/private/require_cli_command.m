function require_cli_command(name)
%REQUIRE_CLI_COMMAND  Fails with a clear message when the kincal CLI on this branch lacks the
%   subcommand NAME (calibrate, predict and validate come with the CLI of main).
help_text = cli('--help');
if isempty(regexp(help_text, ['\n\s+' name '\s'], 'once'))
    error('test:cliCommand', ['the kincal CLI has no ''%s'' command on this branch (it lands ' ...
        'on main with calibrate/predict/validate); cannot cross-check'], name);
end
end
